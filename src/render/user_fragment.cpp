// src/render/user_fragment.cpp — `render` with a user's fragment shader ([shaders] frag or
// `--shader frag=FILE` whose text is not the shading model's twin): the surface is drawn as
// the GL backend draws it and every winning fragment is shaded by the SPIR-V interpreter,
// as llvmpipe (Mesa 22.3) shades it. The shipped twins keep the built-in shading models
// (render.cpp's streamed render): this path is for a shader that has no model.
//
// What each step does, and why it is llvmpipe's:
//  1. The pipeline runs as for any render (run_pipeline, gpu precision); then the last
//     stage before the rasterizer runs on the interpreter at every triangle's corners
//     (pipeline::raster_stage_corners: the user's stages and the twins, with the uniforms of
//     the GL draw), which gives what GL rasterizes, gl_Position, and what the fragment
//     shader reads, the outputs by location, in the order GL draws each triangle.
//  2. The corners' gl_Position are rasterized (raster.h: llvmpipe's clipper, snapping and
//     coverage) with depth LESS: each pixel's winning triangle, and how many fragments
//     reached it.
//  3. Each 2x2 quad (aligned in the framebuffer's rows, row 0 on top, as llvmpipe's quads
//     are in its upside-down window-system framebuffer) is shaded once per triangle that
//     won one of its pixels, as one Executable::fragment batch: the lanes that triangle won
//     are covered, the others helper invocations, so that derivatives and texture()'s
//     implicit lod are the quad's.
//  4. The inputs are interpolated as llvmpipe interpolates them. Its setup
//     (lp_state_setup.c) takes the triangle in the order lp_setup_tri.c hands it on
//     ((v1, v0, v2) for a clockwise triangle, by the sign of the snapped area), window
//     positions as draw computes them (x * (1/w)) * scale + translate, and for each input
//     component a plane a0 + dadx x + dady y relative to the framebuffer origin, in float:
//     the perspective inputs premultiplied by each vertex's 1/w, ooa = 1 / (dx01 dy20 -
//     dy01 dx20), dadx = da01 (dy20 ooa) - da20 (dy01 ooa), dady = da20 (dx01 ooa) - da01
//     (dx20 ooa), a0 = a_v0 - (dadx (x0 - 0.5) + dady (y0 - 0.5)), each operation rounded
//     on its own. The fragment code (lp_bld_interp.c) evaluates a plane at the pixel's
//     integer position with two fused multiply-adds, fma(dady, y, fma(dadx, x, a0)), takes
//     1/w's plane there, w = 1 / (1/w) (a division: gallivm's rcp), and a perspective input
//     is its plane times w. gl_FragCoord is (x + 0.5, height - (y + 0.5), z's plane, 1/w's
//     plane). Triangles the clipper cut (a corner outside a clip plane) are set up here whole,
//     where llvmpipe sets up the clipped polygon's fan with new vertices: those pixels' inputs
//     may differ in the last bits; a triangle with a corner at or behind the eye (w <= 0) is
//     interpolated with the perspective-correct weights of its plane in double instead.
//  5. The output at location 0 is the pixel's colour (a unorm8 framebuffer stores it as
//     render's images do). A fragment that discards writes neither colour nor depth, so the
//     pixel shows what GL's depth test keeps of the others: where nothing else reached the
//     pixel the background; where other fragments did, the test is run again over all of
//     them with their own discards (resolve_behind). A shader that writes gl_FragDepth
//     moves the depth test itself and is refused (an error naming the pixel).
#include "render/user_fragment.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "common/data_dir.h"
#include "common/parallel.h"
#include "pipeline/raster_stage.h"
#include "pipeline/stage_uniforms.h"
#include "raster/raster_internal.h"
#include "render/render_internal.h"
#include "tessref/error.h"
#include "tessref/pipeline.h"
#include "tessref/raster.h"

namespace tessref {

namespace {

// The decorations llvmpipe interpolates otherwise than perspective-correct at the pixel
// centre (SPIR-V's Flat, NoPerspective, Centroid, Sample) on an input that is not a built-in
// (glslang marks gl_PrimitiveID flat): their name for the error, or "" when none.
std::string unsupported_interpolation(const std::vector<std::uint32_t>& spirv) {
    constexpr std::uint32_t op_decorate = 71, op_member_decorate = 72;
    constexpr std::uint32_t builtin = 11, no_perspective = 13, flat = 14, centroid = 16, sample = 17;
    std::vector<std::uint32_t> builtins;
    std::vector<std::pair<std::uint32_t, std::uint32_t>> found;  // target, decoration
    for (std::size_t k = 5; k < spirv.size();) {
        const std::uint32_t op = spirv[k] & 0xffffu, count = spirv[k] >> 16;
        if (count == 0 || k + count > spirv.size()) break;
        if (op == op_decorate && count >= 3) {
            if (spirv[k + 2] == builtin) builtins.push_back(spirv[k + 1]);
            else found.emplace_back(spirv[k + 1], spirv[k + 2]);
        } else if (op == op_member_decorate && count >= 4 && spirv[k + 3] != builtin) {
            found.emplace_back(spirv[k + 1], spirv[k + 3]);
        }
        k += count;
    }
    for (const auto& [target, decoration] : found) {
        if (std::find(builtins.begin(), builtins.end(), target) != builtins.end()) continue;
        switch (decoration) {
            case no_perspective: return "noperspective";
            case flat: return "flat";
            case centroid: return "centroid";
            case sample: return "sample";
            default: break;
        }
    }
    return "";
}

// One plane of llvmpipe's setup: the value a0 + dadx x + dady y at integer pixel (x, y).
struct Plane {
    float a0 = 0.0f, dadx = 0.0f, dady = 0.0f;
    float at(float x, float y) const { return std::fma(dady, y, std::fma(dadx, x, a0)); }
};

// A triangle as llvmpipe's setup takes it (lp_state_setup.c, init_args and calc_coef4).
struct TriangleSetup {
    std::array<int, 3> order{0, 1, 2};  // the corners as setup's v0, v1, v2
    bool front = true;
    bool planes = true;  // false: a corner at or behind the eye (weights in double instead)
    std::array<glm::vec4, 3> win{};  // window x, y (down), z, 1/w of v0, v1, v2
    float x0_center = 0.0f, y0_center = 0.0f, dx01_ooa = 0.0f, dy01_ooa = 0.0f, dx20_ooa = 0.0f, dy20_ooa = 0.0f;
    Plane z, oow;
    Plane plane(float a0, float a1, float a2) const {
        const float da01 = a0 - a1;
        const float da20 = a2 - a0;
        Plane p;
        const float da01_dy20_ooa = da01 * dy20_ooa;
        const float da20_dy01_ooa = da20 * dy01_ooa;
        p.dadx = da01_dy20_ooa - da20_dy01_ooa;
        const float da01_dx20_ooa = da01 * dx20_ooa;
        const float da20_dx01_ooa = da20 * dx01_ooa;
        p.dady = da20_dx01_ooa - da01_dx20_ooa;
        const float dadx_x0 = p.dadx * x0_center;
        const float dady_y0 = p.dady * y0_center;
        const float attr_v0 = dadx_x0 + dady_y0;
        p.a0 = a0 - attr_v0;
        return p;
    }
};

TriangleSetup setup_triangle(const std::array<glm::vec4, 3>& clip, const raster::Viewport& vp) {
    TriangleSetup s;
    std::array<glm::vec4, 3> win;
    for (int k = 0; k < 3; ++k) {
        win[static_cast<std::size_t>(k)] = raster::window_position(clip[static_cast<std::size_t>(k)], vp, false);
        s.planes = s.planes && clip[static_cast<std::size_t>(k)].w > 0.0f && std::isfinite(win[static_cast<std::size_t>(k)].x) &&
                   std::isfinite(win[static_cast<std::size_t>(k)].y);
    }
    if (!s.planes) return s;
    // calc_fixed_position: the snapped positions' area decides the order (triangle_both).
    std::int64_t x[3], y[3];
    for (int k = 0; k < 3; ++k) {
        x[k] = snap_subpixel(win[static_cast<std::size_t>(k)].x);
        y[k] = snap_subpixel(win[static_cast<std::size_t>(k)].y);
    }
    // In 128 bits: a far vertex snaps to the ends of the 32-bit range (its triangle is cut
    // by the clipper; the sign still decides the order of the whole triangle's setup).
    const __int128 area = static_cast<__int128>(x[0] - x[1]) * (y[2] - y[0]) - static_cast<__int128>(x[2] - x[0]) * (y[0] - y[1]);
    s.front = area > 0;  // counter-clockwise in GL window coordinates
    if (area < 0) s.order = {1, 0, 2};  // rotate_fixed_position_01: the provoking vertex stays last
    for (int k = 0; k < 3; ++k) s.win[static_cast<std::size_t>(k)] = win[static_cast<std::size_t>(s.order[static_cast<std::size_t>(k)])];
    const glm::vec4 &v0 = s.win[0], &v1 = s.win[1], &v2 = s.win[2];
    s.x0_center = v0.x - 0.5f;
    s.y0_center = v0.y - 0.5f;
    const float dx01 = v0.x - v1.x, dy01 = v0.y - v1.y;
    const float dx20 = v2.x - v0.x, dy20 = v2.y - v0.y;
    const float e = dx01 * dy20, f = dy01 * dx20;
    const float ooa = 1.0f / (e - f);
    s.dx20_ooa = dx20 * ooa;
    s.dy20_ooa = dy20 * ooa;
    s.dx01_ooa = dx01 * ooa;
    s.dy01_ooa = dy01 * ooa;
    s.z = s.plane(v0.z, v1.z, v2.z);
    s.oow = s.plane(v0.w, v1.w, v2.w);
    return s;
}

}  // namespace

const StageShader* user_fragment_shader(const Scene& scene) {
    const auto it = std::find_if(scene.shaders.begin(), scene.shaders.end(),
                                 [](const StageShader& s) { return s.stage == ShaderStage::fragment; });
    if (it == scene.shaders.end()) return nullptr;
    // The twin's own text keeps the built-in shading model, which it is proven to compute.
    if (pipeline::is_twin(scene, *it)) return nullptr;
    return &*it;
}

namespace render_detail {

StageShader traced_fragment_shader(const Scene& scene) {
    if (const StageShader* user = user_fragment_shader(scene)) return *user;
    const std::string twin = pipeline::twin_file(scene, ShaderStage::fragment);
    if (twin.empty())
        throw Error(std::string("the scene's shading model '") + to_string(scene.shading.model.kind) +
                        "' has no GLSL file to trace (its fragment shader is the GL backend's own text): give one "
                        "with --shader frag=FILE",
                    Where::at_key(scene.file, "shading.model"));
    const std::string path = data_dir() + "/shaders/" + twin;
    return StageShader{ShaderStage::fragment, path, "the shading model's twin", Where::in_file(path)};
}

struct UserFragmentStage::State {
    RenderResult base;  // camera, shading, mvp, pipeline, domain: what render() starts from
    Framebuffer fb;
    std::vector<shader::ShaderVertex> corners;  // three a triangle, GL's order
    bool flipped = false;                      // the mesh's triangles are GL's with corners 1 and 2 swapped
    raster::Viewport viewport;
    std::optional<shader::Module> module;
    shader::Bindings bindings;
    shader::RunOptions options;
    std::optional<shader::Executable> run;
    std::size_t location_count = 0;
    bool colour8 = false;  // RenderOptions::colour8: render() keeps only the 8-bit codes
    void write(RenderResult& result, int x, int row, std::uint32_t triangle, const shader::FragmentResult& r, float depth,
               glm::vec3 barycentric) const;
};

UserFragmentStage::~UserFragmentStage() = default;
std::uint32_t UserFragmentStage::patch_of(std::uint32_t triangle) const {
    const SurfaceMesh& mesh = state_->base.pipeline->mesh;
    return mesh.patch_ids[mesh.triangles[triangle][0]];
}
std::uint32_t UserFragmentStage::shown(int x, int row) const {
    const std::uint32_t t = winner(x, row);
    if (t == kNoTriangle) return kNoPixelId;
    const int lane = (x & 1) + 2 * (row & 1);
    if (!checked_quad(x & ~1, row & ~1, t)[static_cast<std::size_t>(lane)].discarded) return t;
    // Behind a discarded fragment: the whole picture's depth test decides.
    const RenderResult r = render();
    return r.triangle_id[r.index(x, row)];
}
int UserFragmentStage::width() const { return state_->fb.width; }
int UserFragmentStage::height() const { return state_->fb.height; }
std::uint32_t UserFragmentStage::winner(int x, int row) const {
    return state_->fb.triangle_id[static_cast<std::size_t>(row) * static_cast<std::size_t>(state_->fb.width) +
                                  static_cast<std::size_t>(x)];
}

UserFragmentStage::UserFragmentStage(const Scene& scene, const RenderOptions& options, const StageShader& fragment)
    : state_(std::make_unique<State>()) {
    State& s = *state_;
    const Where at = fragment.where;
    if (options.precision != Precision::gpu)
        throw Error("a user's fragment shader runs in gpu precision only (the interpreter is float)", at);
    if (options.camera_relative) throw Error("a user's fragment shader runs without --camera-relative", at);
    if (options.mode != RenderMode::fill)
        throw Error("a user's fragment shader shades filled triangles only (no --wireframe or --overlay-wireframe)", at);
    // The shader first: its errors before the pipeline's work.
    shader::Source source;
    source.stage = ShaderStage::fragment;
    source.path = fragment.path;
    source.text = pipeline::read_user_shader(fragment);
    try {
        s.module.emplace(shader::Module::compile(source));
    } catch (const Error& e) {
        throw Error(std::string(e.what()) + " (" + fragment.origin + ")", e.where());
    }
    if (const std::string q = unsupported_interpolation(s.module->spirv()); !q.empty())
        throw Error("the fragment shader has a " + q +
                        " input: render interpolates perspective-correct inputs at the pixel centre only",
                    Where::in_file(fragment.path));

    s.base.camera = camera_for(scene, options);
    // The pipeline sees the image's viewport, as render_scene runs it.
    Scene pipeline_scene = scene;
    pipeline_scene.camera = s.base.camera;
    s.base.shading = scene.shading;
    s.base.mvp = glm::mat4(s.base.camera.view_projection());
    s.base.domain = scene.generator.domain;
    s.colour8 = options.colour8;
    using Clock = std::chrono::steady_clock;
    const auto seconds_since = [](Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); };
    auto lap = Clock::now();
    PipelineOptions pipeline_options;
    pipeline_options.precision = Precision::gpu;
    pipeline_options.math = options.math;
    auto pipe = std::make_shared<const PipelineResult>(run_pipeline(pipeline_scene, pipeline_options));
    s.base.pipeline = pipe;
    const SurfaceMesh& mesh = pipe->mesh;
    s.base.stats.triangles = mesh.triangles.size();
    s.base.stats.vertices = mesh.positions.size();
    pipeline::RasterStageCorners corners = pipeline::raster_stage_corners(pipeline_scene, mesh, options.math);
    s.corners = std::move(corners.corners);
    s.flipped = corners.flipped;
    s.base.stats.seconds_pipeline = seconds_since(lap);
    lap = Clock::now();

    // The draw: every triangle's three corners as GL rasterizes them.
    const int width = s.base.camera.viewport.x, height = s.base.camera.viewport.y;
    std::vector<glm::vec4> positions(s.corners.size());
    for (std::size_t k = 0; k < positions.size(); ++k) positions[k] = s.corners[k].position;
    std::vector<std::array<std::uint32_t, 3>> triangles(mesh.triangles.size());
    for (std::uint32_t t = 0; t < triangles.size(); ++t) triangles[t] = {3 * t, 3 * t + 1, 3 * t + 2};
    for (const shader::ShaderVertex& v : s.corners) s.location_count = std::max(s.location_count, v.locations.size());
    s.fb = Framebuffer::create(width, height, 0);
    RasterInput input;
    input.positions = positions;
    input.triangles = triangles;
    RasterSettings settings;
    settings.depth_func = DepthFunc::less;
    s.base.stats.raster = rasterize(s.fb, input, settings);
    s.viewport = raster::make_viewport(width, height);
    s.base.stats.seconds_raster = seconds_since(lap);

    // The fragment stage's uniforms and textures, the GL draw's (stage_uniforms.h).
    const pipeline::BindingsSink sink(s.bindings);
    pipeline::set_stage_uniforms(sink, pipeline_scene, pipeline::stage_matrices(pipeline_scene), s.base.camera.viewport);
    pipeline::set_shading_uniforms(sink, scene.shading.model);
    pipeline::bind_program_textures(scene, scene.shading,
                                    [&](int unit, const Texture* t, const std::string&) {
                                        if (t) s.bindings.bind_texture(unit, t);
                                    });
    s.options.math = options.math == MathMode::llvmpipe ? shader::MathMode::llvmpipe : shader::MathMode::exact;
    s.run.emplace(*s.module, s.bindings, s.options);
}

std::array<shader::FragmentResult, 4> UserFragmentStage::quad(int x0, int row0, std::uint32_t triangle,
                                                              std::array<shader::QuadFragment, 4>* inputs_out,
                                                              shader::Observer* observer, int observed_lane) const {
    const State& s = *state_;
    const int width = s.fb.width, height = s.fb.height;
    const shader::ShaderVertex* c = &s.corners[3 * static_cast<std::size_t>(triangle)];
    const std::array<glm::vec4, 3> clip{c[0].position, c[1].position, c[2].position};
    const TriangleSetup setup = setup_triangle(clip, s.viewport);
    std::array<shader::QuadFragment, 4> quad;
    // Each location's four components at the setup's v0, v1, v2, premultiplied by 1/w.
    const std::size_t n = s.location_count;
    std::vector<Plane> planes;
    if (setup.planes) {
        planes.resize(n * 4);
        for (std::size_t j = 0; j < n; ++j)
            for (int k = 0; k < 4; ++k) {
                float a[3];
                for (int v = 0; v < 3; ++v) {
                    const shader::ShaderVertex& corner = c[setup.order[static_cast<std::size_t>(v)]];
                    const float value = j < corner.locations.size() ? shader::as_vec4(corner.locations[j])[k] : 0.0f;
                    a[v] = value * setup.win[static_cast<std::size_t>(v)].w;
                }
                planes[j * 4 + static_cast<std::size_t>(k)] = setup.plane(a[0], a[1], a[2]);
            }
    }
    for (int lane = 0; lane < 4; ++lane) {
        const int x = x0 + (lane & 1), row = row0 + (lane >> 1);
        shader::QuadFragment& f = quad[static_cast<std::size_t>(lane)];
        f.covered = x < width && row < height && winner(x, row) == triangle;
        f.inputs.assign(n, shader::Slot{});
        const float px = static_cast<float>(x), py = static_cast<float>(row);
        if (setup.planes) {
            const float oow = setup.oow.at(px, py);
            const float w = 1.0f / oow;
            f.frag_coord = glm::vec4(px + 0.5f, static_cast<float>(height) - (py + 0.5f), setup.z.at(px, py), oow);
            for (std::size_t j = 0; j < n; ++j) {
                glm::vec4 v;
                for (int k = 0; k < 4; ++k) v[k] = planes[j * 4 + static_cast<std::size_t>(k)].at(px, py) * w;
                f.inputs[j] = shader::slot(v);
            }
        } else {
            // A corner at or behind the eye: the plane's perspective-correct weights in double.
            std::array<glm::dvec4, 3> dclip{glm::dvec4(clip[0]), glm::dvec4(clip[1]), glm::dvec4(clip[2])};
            const glm::dvec3 b = perspective_weights(dclip, pixel_ndc(x, row, width, height));
            const glm::dvec4 p = b.x * dclip[0] + b.y * dclip[1] + b.z * dclip[2];
            f.frag_coord = glm::vec4(px + 0.5f, static_cast<float>(height) - (py + 0.5f),
                                     static_cast<float>(window_depth(p)), static_cast<float>(1.0 / p.w));
            for (std::size_t j = 0; j < n; ++j) {
                glm::vec4 v(0.0f);
                for (int k = 0; k < 3; ++k)
                    if (j < c[k].locations.size()) v += static_cast<float>(b[k]) * shader::as_vec4(c[k].locations[j]);
                f.inputs[j] = shader::slot(v);
            }
        }
    }
    if (inputs_out) *inputs_out = quad;
    const long long primitive = static_cast<long long>(patch_of(triangle));
    if (observer) {
        shader::RunOptions traced = s.options;
        traced.observer = observer;
        traced.observed_lane = observed_lane;
        const shader::Executable run(*s.module, s.bindings, traced);
        return run.fragment(std::span<const shader::QuadFragment, 4>(quad), setup.front, primitive);
    }
    return s.run->fragment(std::span<const shader::QuadFragment, 4>(quad), setup.front, primitive);
}

// A pixel's result: its fragment's colour and provenance written into `result`.
void UserFragmentStage::State::write(RenderResult& result, int x, int row, std::uint32_t t, const shader::FragmentResult& r,
                                     float depth, glm::vec3 b) const {
    const SurfaceMesh& mesh = result.pipeline->mesh;
    const std::size_t i = result.index(x, row);
    result.colour[i] = r.outputs.empty() ? glm::vec4(0.0f) : shader::as_vec4(r.outputs[0]);
    if (flipped) std::swap(b[1], b[2]);  // the mesh's corner order
    const auto& tri = mesh.triangles[t];
    result.patch_id[i] = mesh.patch_ids[tri[0]];
    result.tess_coord[i] = b[0] * mesh.tess_coords[tri[0]] + b[1] * mesh.tess_coords[tri[1]] + b[2] * mesh.tess_coords[tri[2]];
    result.level[i] = triangle_level(*result.pipeline, result.domain, t);
    result.barycentric[i] = b;
    result.depth[i] = depth;
    result.triangle_id[i] = t;
}

std::array<shader::FragmentResult, 4> UserFragmentStage::checked_quad(int x0, int row0, std::uint32_t triangle) const {
    std::array<shader::FragmentResult, 4> out = quad(x0, row0, triangle);
    for (int l = 0; l < 4; ++l)
        if (out[static_cast<std::size_t>(l)].depth_written)
            throw Error("the fragment shader writes gl_FragDepth, which would move the depth test: render does not "
                        "run it (pixel " + std::to_string(x0 + (l & 1)) + "," + std::to_string(row0 + (l >> 1)) + ")",
                        Where::in_file(state_->module->path()));
    return out;
}

RenderResult UserFragmentStage::render() const {
    const State& s = *state_;
    const auto start = std::chrono::steady_clock::now();
    RenderResult result = s.base;
    const int width = s.fb.width, height = s.fb.height;
    allocate(result, width, height, true, true);
    // Pixels whose winning fragment discarded while other fragments reached them: resolved
    // after the pass, from every fragment that reached them.
    std::vector<std::uint8_t> behind(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), 0);
    tessref::parallel_for(tbb::blocked_range<int>(0, (height + 1) / 2), [&](const tbb::blocked_range<int>& rows) {
        for (int quad_row = rows.begin(); quad_row < rows.end(); ++quad_row) {
            const int row0 = 2 * quad_row;
            for (int x0 = 0; x0 < width; x0 += 2) {
                std::uint32_t shaded[4];
                int count = 0;
                for (int lane = 0; lane < 4; ++lane) {
                    const int x = x0 + (lane & 1), row = row0 + (lane >> 1);
                    if (x >= width || row >= height) continue;
                    const std::uint32_t t = winner(x, row);
                    if (t == kNoTriangle || std::find(shaded, shaded + count, t) != shaded + count) continue;
                    shaded[count++] = t;
                    const std::array<shader::FragmentResult, 4> out = checked_quad(x0, row0, t);
                    for (int l = 0; l < 4; ++l) {
                        const int lx = x0 + (l & 1), lrow = row0 + (l >> 1);
                        if (lx >= width || lrow >= height || winner(lx, lrow) != t) continue;
                        const shader::FragmentResult& r = out[static_cast<std::size_t>(l)];
                        const std::size_t i = result.index(lx, lrow);
                        if (r.discarded) {
                            // Alone at the pixel: the background shows; else what is behind.
                            if (s.fb.fragment_count[i] > 1) behind[i] = 1;
                            continue;
                        }
                        s.write(result, lx, lrow, t, r, s.fb.depth[i], s.fb.barycentric[i]);
                    }
                }
            }
        }
    });
    resolve_behind(result, behind);
    std::uint64_t covered = 0;
    for (const std::uint32_t id : result.triangle_id) covered += id != kNoPixelId;
    result.stats.covered_pixels = covered;
    if (s.colour8) keep_colour8(result);
    result.stats.seconds_shade = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    return result;
}

// The pixels whose winning fragment discarded, where other fragments reached them: GL's
// depth test run again over every fragment that reached each such pixel, in submission
// order, with the shader's discards (depth LESS, cleared to 1; a discarded fragment writes
// nothing). Each triangle whose window box holds such a pixel (or that the clipper cuts at
// the eye) is rasterized alone, depth ALWAYS, into a scratch buffer: the pixels it writes
// are its fragments, with the depth the pass computed. Only those triangles, one draw each.
void UserFragmentStage::resolve_behind(RenderResult& result, const std::vector<std::uint8_t>& behind) const {
    const State& s = *state_;
    const int width = s.fb.width, height = s.fb.height;
    if (std::find(behind.begin(), behind.end(), 1) == behind.end()) return;
    // Prefix sums of the pixels to resolve: whether a box holds one, in constant time.
    const std::size_t w1 = static_cast<std::size_t>(width) + 1;
    std::vector<std::uint32_t> sum(w1 * (static_cast<std::size_t>(height) + 1), 0);
    for (int row = 0; row < height; ++row)
        for (int x = 0; x < width; ++x)
            sum[(static_cast<std::size_t>(row) + 1) * w1 + static_cast<std::size_t>(x) + 1] =
                behind[result.index(x, row)] + sum[static_cast<std::size_t>(row) * w1 + static_cast<std::size_t>(x) + 1] +
                sum[(static_cast<std::size_t>(row) + 1) * w1 + static_cast<std::size_t>(x)] -
                sum[static_cast<std::size_t>(row) * w1 + static_cast<std::size_t>(x)];
    const auto any_in = [&](int x0, int r0, int x1, int r1) {  // inclusive, clamped
        x0 = std::max(x0, 0), r0 = std::max(r0, 0), x1 = std::min(x1, width - 1), r1 = std::min(r1, height - 1);
        if (x0 > x1 || r0 > r1) return false;
        const auto at = [&](int x, int r) { return sum[static_cast<std::size_t>(r) * w1 + static_cast<std::size_t>(x)]; };
        return at(x1 + 1, r1 + 1) - at(x0, r1 + 1) - at(x1 + 1, r0) + at(x0, r0) > 0;
    };
    struct Fragment {
        std::uint32_t triangle;
        float depth;
        glm::vec3 barycentric;
    };
    std::vector<std::vector<Fragment>> fragments(behind.size());
    Framebuffer scratch = Framebuffer::create_visibility(width, height);
    RasterSettings settings;
    settings.depth_func = DepthFunc::always;
    Rasterizer rasterizer(scratch, settings);
    const std::size_t triangles = s.corners.size() / 3;
    for (std::uint32_t t = 0; t < triangles; ++t) {
        const shader::ShaderVertex* c = &s.corners[3 * static_cast<std::size_t>(t)];
        float lo_x = INFINITY, lo_y = INFINITY, hi_x = -INFINITY, hi_y = -INFINITY;
        bool bounded = true;
        for (int k = 0; k < 3; ++k) {
            const glm::vec4 win = raster::window_position(c[k].position, s.viewport, false);
            bounded = bounded && c[k].position.w > 0.0f && std::isfinite(win.x) && std::isfinite(win.y);
            lo_x = std::min(lo_x, win.x), hi_x = std::max(hi_x, win.x);
            lo_y = std::min(lo_y, win.y), hi_y = std::max(hi_y, win.y);
        }
        // The box one pixel wider, clamped into the image before it is made integer.
        const auto column = [&](float v) { return static_cast<int>(std::clamp(v, -2.0f, static_cast<float>(width) + 2.0f)); };
        const auto row_of = [&](float v) { return static_cast<int>(std::clamp(v, -2.0f, static_cast<float>(height) + 2.0f)); };
        if (bounded && !any_in(column(std::floor(lo_x)) - 1, row_of(std::floor(lo_y)) - 1, column(std::ceil(hi_x)) + 1,
                               row_of(std::ceil(hi_y)) + 1))
            continue;
        const glm::vec4 positions[3] = {c[0].position, c[1].position, c[2].position};
        const std::array<std::uint32_t, 3> one{0, 1, 2};
        const RasterChunk chunk{positions, std::span<const std::array<std::uint32_t, 3>>(&one, 1), t};
        rasterizer.draw(std::span<const RasterChunk>(&chunk, 1));
        for (const Rasterizer::Rect& r : rasterizer.drawn())
            for (int row = r.row; row < std::min(r.row + r.height, height); ++row)
                for (int x = r.x; x < std::min(r.x + r.width, width); ++x) {
                    const std::size_t i = result.index(x, row);
                    if (behind[i] && scratch.triangle_id[i] == t)
                        fragments[i].push_back({t, scratch.depth[i], r.weights.at(x, row)});
                }
    }
    tessref::parallel_for(tbb::blocked_range<int>(0, height), [&](const tbb::blocked_range<int>& rows) {
        for (int row = rows.begin(); row < rows.end(); ++row)
            for (int x = 0; x < width; ++x) {
                const std::size_t i = result.index(x, row);
                if (!behind[i]) continue;
                float stored = 1.0f;
                for (const Fragment& f : fragments[i]) {
                    if (!(f.depth < stored)) continue;
                    const int lane = (x & 1) + 2 * (row & 1);
                    const shader::FragmentResult r = checked_quad(x & ~1, row & ~1, f.triangle)[static_cast<std::size_t>(lane)];
                    if (r.discarded) continue;
                    stored = f.depth;
                    s.write(result, x, row, f.triangle, r, f.depth, f.barycentric);
                }
            }
    });
}

RenderResult render_user_fragment(const Scene& scene, const RenderOptions& options, const StageShader& fragment) {
    return UserFragmentStage(scene, options, fragment).render();
}

}  // namespace render_detail

}  // namespace tessref
