// Building GL programs from shader files: see program.h.
#include "gl/program.h"

#include <algorithm>
#include <fstream>
#include <regex>
#include <sstream>
#include <string_view>
#include <utility>

#include "common/data_dir.h"
#include "common/input_file.h"
#include "common/isolated.h"

namespace tessref::gl {

std::string shader_data_dir() { return data_dir(); }

std::string read_shader(const std::string& name) {
    const std::string path = shader_data_dir() + "/shaders/" + name;
    return read_input_file(path, "shader file", kShaderFileBytes);
}

const char* stage_name(GLenum stage) {
    switch (stage) {
        case GL_VERTEX_SHADER: return "vertex";
        case GL_TESS_CONTROL_SHADER: return "tess_control";
        case GL_TESS_EVALUATION_SHADER: return "tess_evaluation";
        case GL_GEOMETRY_SHADER: return "geometry";
        case GL_FRAGMENT_SHADER: return "fragment";
        default: return "unknown";
    }
}

int log_line(const std::string& log) {
    std::smatch m;
    if (std::regex_search(log, m, std::regex(R"(\d+:(\d+)\(\d+\))"))) return std::stoi(m[1].str());
    return 0;
}

namespace {

// Where the line of the #version directive ends and that line's number ({0, 0}: none).
// The directive may follow blank lines and comments (a user's file often starts with one).
std::pair<std::size_t, int> version_line(const std::string& text) {
    std::size_t pos = 0;
    for (int line = 1; pos < text.size(); ++line) {
        std::size_t end = text.find('\n', pos);
        if (end == std::string::npos) end = text.size();
        std::string_view l(text.data() + pos, end - pos);
        const auto directive = [&l]() {
            std::size_t i = l.find_first_not_of(" \t");
            if (i == std::string_view::npos || l[i] != '#') return false;
            i = l.find_first_not_of(" \t", i + 1);
            return i != std::string_view::npos && l.substr(i, 7) == "version";
        };
        if (directive()) return {end == text.size() ? end : end + 1, line};
        pos = end + 1;
    }
    return {0, 0};
}

std::string trimmed_log(std::string log) {
    log = log.c_str();  // up to the terminating zero GL wrote
    while (!log.empty() && (log.back() == '\n' || log.back() == ' ')) log.pop_back();
    return log;
}

std::string shown_path(const StageSource& s) { return s.path.empty() ? std::string("(built-in shader)") : s.path; }

// "the tess_evaluation shader x.tese (--shader tese=x.tese)"
std::string described(const StageSource& s) {
    return std::string("the ") + stage_name(s.stage) + " shader " + shown_path(s) +
           (s.origin.empty() ? "" : " (user shader, " + s.origin + ")");
}

}  // namespace

GLuint compile(GlFunctions& gl, const StageSource& s) {
    const auto [split, line] = version_line(s.text);
    std::string head = s.text.substr(0, split);
    if (!head.empty() && head.back() != '\n') head += '\n';
    const std::string inserted = s.prefix + "#line " + std::to_string(line + 1) + "\n";
    const std::string tail = s.text.substr(split) + "\n" + s.suffix;
    const GLchar* parts[] = {head.c_str(), inserted.c_str(), tail.c_str()};
    set_isolated_phase("compiling " + described(s), Where::in_file(shown_path(s)));
    const GLuint shader = gl.CreateShader(s.stage);
    gl.ShaderSource(shader, 3, parts, nullptr);
    gl.CompileShader(shader);
    GLint ok = GL_FALSE;
    gl.GetShaderiv(shader, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        GLint length = 0;
        gl.GetShaderiv(shader, GL_INFO_LOG_LENGTH, &length);
        std::string log(static_cast<std::size_t>(std::max(length, 1)), '\0');
        gl.GetShaderInfoLog(shader, length, nullptr, log.data());
        gl.DeleteShader(shader);
        log = trimmed_log(log);
        Where where;
        where.file = shown_path(s);
        where.line = log_line(log);
        throw Error("GLSL compile error in " + described(s) + ": " + log, where);
    }
    return shader;
}

GLuint link(GlFunctions& gl, const std::vector<StageSource>& stages, const std::vector<const char*>& varyings,
            const std::string& what) {
    std::vector<GLuint> shaders;
    try {
        for (const StageSource& s : stages) shaders.push_back(compile(gl, s));
    } catch (...) {
        for (GLuint shader : shaders) gl.DeleteShader(shader);
        throw;
    }
    const GLuint program = gl.CreateProgram();
    for (GLuint shader : shaders) gl.AttachShader(program, shader);
    if (!varyings.empty())
        gl.TransformFeedbackVaryings(program, static_cast<GLsizei>(varyings.size()), varyings.data(),
                                     GL_INTERLEAVED_ATTRIBS);
    std::string users;  // the user's files among the stages: what the phase names
    for (const StageSource& s : stages)
        if (!s.origin.empty()) users += (users.empty() ? "" : ", ") + s.path;
    set_isolated_phase("linking " + what + (users.empty() ? "" : " (user shaders: " + users + ")"),
                       users.empty() ? Where() : Where::in_file(users));
    gl.LinkProgram(program);
    for (GLuint shader : shaders) gl.DeleteShader(shader);
    GLint ok = GL_FALSE;
    gl.GetProgramiv(program, GL_LINK_STATUS, &ok);
    if (!ok) {
        GLint length = 0;
        gl.GetProgramiv(program, GL_INFO_LOG_LENGTH, &length);
        std::string log(static_cast<std::size_t>(std::max(length, 1)), '\0');
        gl.GetProgramInfoLog(program, length, nullptr, log.data());
        gl.DeleteProgram(program);
        std::string files;
        for (const StageSource& s : stages)
            files += (files.empty() ? "" : ", ") + std::string(stage_name(s.stage)) + " " + shown_path(s) +
                     (s.origin.empty() ? "" : " (user shader, " + s.origin + ")");
        Where where;
        where.file = files;
        throw Error("GLSL link error in " + what + ": " + trimmed_log(log), where);
    }
    return program;
}

}  // namespace tessref::gl
