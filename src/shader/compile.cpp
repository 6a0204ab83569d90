// The shader front end: GLSL -> SPIR-V with glslang's library, validated by SPIRV-Tools.
//
// The GLSL is OpenGL's (the twins and a user's shaders are written for `tessref gl`), so the
// client is OpenGL (ARB_gl_spirv): loose uniforms such as `uniform float scaleXY;` stay
// UniformConstant variables, which Vulkan SPIR-V would refuse; their locations are mapped
// automatically and the interpreter binds them by their OpName, as glUniform* binds them
// by name. Debug information is kept (OpLine, OpName), and glslang's optimizer is off: the
// interpreter runs the operations in the order the source writes them.
#include <mutex>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include <glslang/Public/ResourceLimits.h>
#include <glslang/Public/ShaderLang.h>
#include <glslang/SPIRV/GlslangToSpv.h>
#include <glslang/SPIRV/spirv.hpp>
#include <spirv-tools/libspirv.hpp>

#include "shader/module.h"

namespace tessref::shader {

namespace {

EShLanguage language(ShaderStage stage) {
    switch (stage) {
        case ShaderStage::vertex: return EShLangVertex;
        case ShaderStage::tess_control: return EShLangTessControl;
        case ShaderStage::tess_evaluation: return EShLangTessEvaluation;
        case ShaderStage::geometry: return EShLangGeometry;
        case ShaderStage::fragment: return EShLangFragment;
    }
    return EShLangVertex;
}

// glslang's process-wide tables, built once (InitializeProcess is not re-entrant).
void initialize_glslang() {
    static std::once_flag once;
    std::call_once(once, [] { glslang::InitializeProcess(); });
}

// Where the line of the #version directive ends and that line's number ({0, 0}: none), as
// the GL backend splits a source (src/gl/program.cpp) to insert its #defines.
std::pair<std::size_t, int> version_line(const std::string& text) {
    std::size_t pos = 0;
    for (int line = 1; pos < text.size(); ++line) {
        std::size_t end = text.find('\n', pos);
        if (end == std::string::npos) end = text.size();
        const std::string_view l(text.data() + pos, end - pos);
        std::size_t i = l.find_first_not_of(" \t");
        if (i != std::string_view::npos && l[i] == '#') {
            i = l.find_first_not_of(" \t", i + 1);
            if (i != std::string_view::npos && l.substr(i, 7) == "version")
                return {end == text.size() ? end : end + 1, line};
        }
        pos = end + 1;
    }
    return {0, 0};
}

// The line of glslang's first "ERROR: <string>:LINE: ..." (0 when there is none).
int log_line(const std::string& log) {
    std::smatch m;
    if (std::regex_search(log, m, std::regex(R"(ERROR: [^:\n]*:(\d+):)"))) return std::atoi(m[1].str().c_str());
    return 0;
}

std::string trimmed(std::string s) {
    while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
    return s;
}

}  // namespace

std::vector<std::uint32_t> compile_glsl(const Source& source) {
    initialize_glslang();
    const std::string name = source.path.empty() ? std::string("(built-in shader)") : source.path;
    // The text as two strings: up to the #version line, then the prefix, a #line that
    // restores the file's numbering and the rest (glslang numbers each string's lines from
    // 1, so the #line and the text it numbers share one string).
    const auto [split, line] = version_line(source.text);
    std::string head = source.text.substr(0, split);
    if (!head.empty() && head.back() != '\n') head += '\n';
    const std::string tail = source.prefix + "#line " + std::to_string(line + 1) + "\n" + source.text.substr(split) + "\n";
    const char* strings[] = {head.c_str(), tail.c_str()};
    const int lengths[] = {static_cast<int>(head.size()), static_cast<int>(tail.size())};
    const char* names[] = {name.c_str(), name.c_str()};

    const EShLanguage stage = language(source.stage);
    glslang::TShader shader(stage);
    shader.setStringsWithLengthsAndNames(strings, lengths, names, 2);
    shader.setEnvInput(glslang::EShSourceGlsl, stage, glslang::EShClientOpenGL, 100);
    shader.setEnvClient(glslang::EShClientOpenGL, glslang::EShTargetOpenGL_450);
    shader.setEnvTarget(glslang::EShTargetSpv, glslang::EShTargetSpv_1_0);
    shader.setAutoMapLocations(true);
    shader.setAutoMapBindings(true);
    const auto messages = static_cast<EShMessages>(EShMsgSpvRules | EShMsgDebugInfo);
    if (!shader.parse(GetDefaultResources(), 450, ECoreProfile, false, false, messages))
        throw Error(std::string("GLSL compile error in the ") + to_string(source.stage) + " shader " + name + ": " +
                        trimmed(shader.getInfoLog()),
                    Where::in_file(name, static_cast<std::size_t>(log_line(shader.getInfoLog()))));
    glslang::TProgram program;
    program.addShader(&shader);
    if (!program.link(messages) || !program.mapIO())
        throw Error(std::string("GLSL link error in the ") + to_string(source.stage) + " shader " + name + ": " +
                        trimmed(program.getInfoLog()),
                    Where::in_file(name));

    std::vector<std::uint32_t> spirv;
    spv::SpvBuildLogger logger;
    glslang::SpvOptions options;
    options.generateDebugInfo = true;
    options.disableOptimizer = true;
    options.validate = false;  // validated below, with the message kept
    glslang::GlslangToSpv(*program.getIntermediate(stage), spirv, &logger, &options);
    const std::string messages_text = logger.getAllMessages();
    if (spirv.empty())
        throw Error("glslang produced no SPIR-V for " + name + ": " + trimmed(messages_text), Where::in_file(name));
    return spirv;
}

void validate_spirv(const std::vector<std::uint32_t>& spirv, const std::string& path) {
    spvtools::SpirvTools tools(SPV_ENV_OPENGL_4_5);
    std::string message;
    tools.SetMessageConsumer([&message](spv_message_level_t, const char*, const spv_position_t& position,
                                        const char* text) {
        if (message.empty()) message = "word " + std::to_string(position.index) + ": " + text;
    });
    if (tools.Validate(spirv)) return;
    // glslang's OpenGL SPIR-V keeps `uniform bool x;` a bool UniformConstant variable, which
    // the validator refuses (a bool has no defined memory layout; the interpreter needs
    // none, it binds uniforms by name). Such a module is validated once more as if those
    // variables were Private; any other problem is still found.
    if (message.find("OpTypeBool is stored") != std::string::npos) {
        std::vector<std::uint32_t> copy = spirv;
        std::set<std::uint32_t> bools, bool_pointers;
        for (std::size_t pos = 5; pos < copy.size() && (copy[pos] >> 16) > 0; pos += copy[pos] >> 16) {
            const std::uint32_t op = copy[pos] & 0xffff, n = copy[pos] >> 16;
            if (pos + n > copy.size()) break;
            if (op == spv::OpTypeBool) bools.insert(copy[pos + 1]);
            if (op == spv::OpTypePointer && copy[pos + 2] == spv::StorageClassUniformConstant &&
                bools.count(copy[pos + 3])) {
                copy[pos + 2] = spv::StorageClassPrivate;
                bool_pointers.insert(copy[pos + 1]);
            }
            if (op == spv::OpVariable && bool_pointers.count(copy[pos + 1])) copy[pos + 3] = spv::StorageClassPrivate;
        }
        std::string first = std::move(message);
        message.clear();
        if (tools.Validate(copy)) return;
        if (message.empty()) message = first;
    }
    throw Error("SPIR-V validation failed: " + (message.empty() ? std::string("(no message)") : message),
                Where::in_file(path));
}

Module Module::compile(const Source& source) {
    std::vector<std::uint32_t> spirv = compile_glsl(source);
    return load(std::move(spirv), source.path.empty() ? std::string("(built-in shader)") : source.path);
}

}  // namespace tessref::shader
