// The offscreen OSMesa OpenGL 4.5 core context (Mesa llvmpipe).
#include <dlfcn.h>

#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <string>
#include <type_traits>
#include <utility>

#include "gl/gl_api.h"
#include "tessref/error.h"

#ifndef TESSREF_OSMESA_LIBRARY
#error "TESSREF_OSMESA_LIBRARY (libOSMesa's soname) comes from CMakeLists.txt"
#endif

namespace tessref::gl {

namespace {

// libOSMesa, loaded on the first context: it brings LLVM (llvmpipe), whose loading and
// relocation cost every tessref process some 20 ms before main() when linked, GL or not.
// Its five OSMesa entry points are taken here; the GL functions through GetProcAddress.
struct OsMesa {
    decltype(&::OSMesaCreateContextAttribs) CreateContextAttribs = nullptr;
    decltype(&::OSMesaMakeCurrent) MakeCurrent = nullptr;
    decltype(&::OSMesaGetCurrentContext) GetCurrentContext = nullptr;
    decltype(&::OSMesaDestroyContext) DestroyContext = nullptr;
    decltype(&::OSMesaGetProcAddress) GetProcAddress = nullptr;
    std::string failure;
};

const OsMesa& osmesa_library() {
    static OsMesa lib;
    static std::once_flag once;
    std::call_once(once, [] {
        void* handle = dlopen(TESSREF_OSMESA_LIBRARY, RTLD_NOW | RTLD_LOCAL);
        if (handle == nullptr) {
            const char* reason = dlerror();
            lib.failure = std::string("cannot load " TESSREF_OSMESA_LIBRARY ": ") + (reason ? reason : "unknown reason") +
                          " (Debian: libosmesa6)";
            return;
        }
        std::string missing;
        const auto take = [&](auto& slot, const char* name) {
            slot = reinterpret_cast<std::remove_reference_t<decltype(slot)>>(dlsym(handle, name));
            if (slot == nullptr) missing += (missing.empty() ? "" : ", ") + std::string(name);
        };
        take(lib.CreateContextAttribs, "OSMesaCreateContextAttribs");
        take(lib.MakeCurrent, "OSMesaMakeCurrent");
        take(lib.GetCurrentContext, "OSMesaGetCurrentContext");
        take(lib.DestroyContext, "OSMesaDestroyContext");
        take(lib.GetProcAddress, "OSMesaGetProcAddress");
        if (!missing.empty()) lib.failure = TESSREF_OSMESA_LIBRARY " lacks " + missing;
    });
    if (!lib.failure.empty()) throw Error("OSMesa: " + lib.failure);
    return lib;
}

const char* error_name(GLenum error) {
    switch (error) {
        case GL_INVALID_ENUM: return "GL_INVALID_ENUM";
        case GL_INVALID_VALUE: return "GL_INVALID_VALUE";
        case GL_INVALID_OPERATION: return "GL_INVALID_OPERATION";
        case GL_INVALID_FRAMEBUFFER_OPERATION: return "GL_INVALID_FRAMEBUFFER_OPERATION";
        case GL_OUT_OF_MEMORY: return "GL_OUT_OF_MEMORY";
        default: return "unknown GL error";
    }
}

}  // namespace

void Context::Impl::make_current() {
    const OsMesa& os = osmesa_library();
    if (os.GetCurrentContext() == osmesa) return;
    if (!os.MakeCurrent(osmesa, color_buffer.data(), GL_UNSIGNED_BYTE, 1, 1))
        throw Error("OSMesa: cannot make the GL context current");
}

void Context::Impl::bind_color_buffer(float* pixels, int width, int height) {
    if (!osmesa_library().MakeCurrent(osmesa, pixels, GL_FLOAT, width, height))
        throw Error("OSMesa: cannot bind a " + std::to_string(width) + "x" + std::to_string(height) +
                    " float colour buffer");
}

void Context::Impl::release_color_buffer() {
    if (!osmesa_library().MakeCurrent(osmesa, color_buffer.data(), GL_UNSIGNED_BYTE, 1, 1))
        throw Error("OSMesa: cannot make the GL context current");
}

void Context::Impl::check_error(const char* what) {
    const GLenum error = gl.GetError();
    if (error == GL_NO_ERROR) return;
    char code[16];
    std::snprintf(code, sizeof code, "0x%04x", error);
    throw Error(std::string("OpenGL error ") + error_name(error) + " (" + code + ") in " + what);
}

Context::Impl::~Impl() {
    if (!osmesa) return;
    const OsMesa& os = osmesa_library();  // loaded: this context came from it
    if (os.GetCurrentContext() == osmesa || os.MakeCurrent(osmesa, color_buffer.data(), GL_UNSIGNED_BYTE, 1, 1)) {
        for (auto& [key, program] : programs)
            if (program.program) gl.DeleteProgram(program.program);
        const GLuint buffers[] = {level_buffer, feedback_buffer};
        if (gl.DeleteBuffers) gl.DeleteBuffers(2, buffers);
        const GLuint queries[] = {query_generated, query_written};
        if (gl.DeleteQueries) gl.DeleteQueries(2, queries);
        if (gl.DeleteVertexArrays && vertex_array) gl.DeleteVertexArrays(1, &vertex_array);
    }
    os.DestroyContext(osmesa);
}

Context Context::create() {
    // Mesa's OSMesa dereferences a null screen when GALLIUM_DRIVER names a driver it cannot
    // load (Mesa 22.3: a segmentation fault in OSMesaCreateContextAttribs): refused first.
    if (const char* driver = std::getenv("GALLIUM_DRIVER");
        driver && *driver && std::string(driver) != "llvmpipe" && std::string(driver) != "softpipe") {
        throw Error(std::string("OSMesa: GALLIUM_DRIVER=") + driver +
                        " is not a software driver OSMesa can load (llvmpipe, softpipe); tessref gl needs llvmpipe",
                    Where::in_file("GALLIUM_DRIVER"));
    }
    const OsMesa& os = osmesa_library();
    auto impl = std::make_unique<Impl>();
    const int attributes[] = {OSMESA_FORMAT,
                              OSMESA_RGBA,
                              OSMESA_DEPTH_BITS,
                              24,  // the scene renderer's depth test (scene_render.cpp)
                              OSMESA_STENCIL_BITS,
                              0,
                              OSMESA_ACCUM_BITS,
                              0,
                              OSMESA_PROFILE,
                              OSMESA_CORE_PROFILE,
                              OSMESA_CONTEXT_MAJOR_VERSION,
                              4,
                              OSMESA_CONTEXT_MINOR_VERSION,
                              5,
                              0};
    impl->osmesa = os.CreateContextAttribs(attributes, nullptr);
    if (!impl->osmesa)
        throw Error(
            "OSMesa: cannot create an OpenGL 4.5 core-profile context (is libOSMesa built with "
            "llvmpipe, and does it support GL 4.5? try GALLIUM_DRIVER=llvmpipe)");
    impl->color_buffer.assign(4, 0);
    impl->make_current();

    std::string missing;
#define TESSREF_GL_LOAD(name, ret, params)                                                   \
    impl->gl.name = reinterpret_cast<ret(GLAPIENTRY*) params>(os.GetProcAddress("gl" #name));     \
    if (!impl->gl.name) missing += (missing.empty() ? "gl" : ", gl") + std::string(#name);
    TESSREF_GL_FUNCTIONS(TESSREF_GL_LOAD)
#undef TESSREF_GL_LOAD
    if (!missing.empty())
        throw Error("OSMesa: OpenGL functions not available: " + missing);

    auto gl_string = [&](GLenum name) {
        const GLubyte* s = impl->gl.GetString(name);
        return s ? std::string(reinterpret_cast<const char*>(s)) : std::string("(unknown)");
    };
    impl->renderer = gl_string(GL_RENDERER);
    impl->version = gl_string(GL_VERSION);
    GLint major = 0, minor = 0;
    impl->gl.GetIntegerv(GL_MAJOR_VERSION, &major);
    impl->gl.GetIntegerv(GL_MINOR_VERSION, &minor);
    if (major < 4 || (major == 4 && minor < 5))
        throw Error("OSMesa: OpenGL 4.5 is required, the context reports " + impl->version +
                    " (" + impl->renderer + ")");
    impl->check_error("context creation");
    return Context(std::move(impl));
}

Context::Context(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Context::Context(Context&&) noexcept = default;
Context& Context::operator=(Context&&) noexcept = default;
Context::~Context() = default;

const std::string& Context::renderer() const { return impl_->renderer; }
const std::string& Context::version() const { return impl_->version; }

}  // namespace tessref::gl
