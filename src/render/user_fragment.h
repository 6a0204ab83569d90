// src/render/user_fragment.h — a user's fragment shader run by the render (private to
// src/render/ and the trace command): the scene's surface drawn as the GL pipeline draws it,
// each winning fragment's quad shaded by the SPIR-V interpreter (user_fragment.cpp).
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include "tessref/render.h"
#include "tessref/scene.h"
#include "tessref/shader.h"

namespace tessref::render_detail {

// The user's fragment shader as the render runs it: the scene drawn (the last stage
// before the rasterizer on the interpreter, rasterized), the module with the uniforms and
// textures of the GL backend's draw. Built once; quad() is const and thread-safe.
class UserFragmentStage {
public:
    // Throws tessref::Error for what the CPU does not run (exact precision, camera-relative
    // evaluation, a wireframe, a geomipmapped terrain, flat, noperspective, centroid or sample
    // inputs), the shader's compile errors (naming its [shaders] key or flag) and the
    // interpreter's.
    // The image size is options.size, else the camera's viewport (render_scene's rule).
    UserFragmentStage(const Scene& scene, const RenderOptions& options, const StageShader& fragment);
    ~UserFragmentStage();

    int width() const;
    int height() const;
    // The triangle whose fragment passed the depth test last at image pixel (x, row), row 0
    // on top; kNoPixelId where none did.
    std::uint32_t winner(int x, int row) const;
    // The fragment shader's four invocations of the 2x2 quad whose top-left pixel is (x0,
    // row0) (both even) for `triangle`, its inputs interpolated at each lane as llvmpipe
    // interpolates them; a lane is covered where `triangle` won the pixel. `options`
    // replaces the stage's run options (an observer for `tessref trace`) when given.
    std::array<shader::FragmentResult, 4> quad(int x0, int row0, std::uint32_t triangle,
                                               std::array<shader::QuadFragment, 4>* inputs = nullptr,
                                               shader::Observer* observer = nullptr, int observed_lane = 0) const;
    // The triangle whose fragment the pixel shows after the depth test and the shader's
    // discards (a discarded fragment leaves the pixel to what is behind it); kNoPixelId
    // where none does.
    std::uint32_t shown(int x, int row) const;
    // The patch of a triangle (gl_PrimitiveID of its fragments).
    std::uint32_t patch_of(std::uint32_t triangle) const;
    // Every pixel shaded: the image, its visibility and provenance buffers.
    RenderResult render() const;

    struct State;

private:
    // The pixels of `result` whose winner discarded (with other fragments there) resolved.
    // quad(), refusing a shader that writes gl_FragDepth.
    std::array<shader::FragmentResult, 4> checked_quad(int x0, int row0, std::uint32_t triangle) const;
    void resolve_behind(RenderResult& result, const std::vector<std::uint8_t>& behind) const;
    std::unique_ptr<State> state_;
};

// The fragment shader `tessref trace --stage frag` runs: the user's (user_fragment_shader),
// else the shading model's GLSL twin. Throws tessref::Error for flat and depth shading
// without a user's file (their shaders are the GL backend's own text, not a file).
StageShader traced_fragment_shader(const Scene& scene);

// render_scene() for a scene whose user_fragment_shader() is `fragment`.
RenderResult render_user_fragment(const Scene& scene, const RenderOptions& options, const StageShader& fragment);

}  // namespace tessref::render_detail
