// tessref/render.h — a scene to a picture: the golden image and the provenance of every pixel.
//
//   scene ─► run_pipeline ─► gl_Position = mvp * vec4(position, 1) (float, as the shaders;
//                            camera_relative: the eye-relative position, RenderOptions)
//         ─► rasterize (raster.h: llvmpipe's coverage, depth LESS) ─► shade (shading.h)
//
// render_scene() runs the scene's pipeline, projects the tessellated surface with the scene's
// camera, rasterizes it and runs the scene's fragment stage (Scene::shading, its [shading]
// table: data/scenes/README.md) on every visible pixel. Besides the colour it keeps, per pixel, where the pixel came from
// (RenderResult): the patch, the triangle, the interpolated gl_TessCoord, the tessellation
// level that governed the triangle, the depth. pixel_provenance() gathers them for one pixel.
//
// raytrace_scene() is the ground truth for the speed/accuracy study: the same camera and the
// same fragment stage, but the surface is the full-resolution height field itself, not a
// tessellation, intersected with Embree (raycast.h).
//
// IMAGES. Every per-pixel vector has width * height entries, row-major, row 0 the TOP row of
// the picture (raster.h's order, the order image files are written in). Pixel (x, y) in
// this header means column x from the left and row y from the top, as an image viewer
// shows it; GL window coordinates are (x, height - 1 - y).
//
// FRAGMENT INPUTS. The rasterizer's perspective-correct weights of the visible triangle
// interpolate the mesh's positions, normals and uvs (FragmentInputs). A face-normal scene
// ([geometry] normals = "face") reads its triangle's normal, as the geometry shader emits it
// on all three vertices. dFdx/dFdy of the texture coordinate are per 2x2 quad, as llvmpipe
// computes them: for a pixel in the quad whose top-left pixel is (qx, qy), the visible
// triangle's interpolation evaluated at the centres of (qx + 1, qy) minus (qx, qy), and of
// (qx, qy) minus (qx, qy + 1) (window y grows upwards), evaluating the triangle's plane
// outside the triangle where the quad leaves it (helper pixels). In wireframe mode the
// visible primitive is a line, and its interpolation is the line's (along its major axis
// only, constant across it; raster.h Framebuffer::barycentric_dx/dy), as llvmpipe's.
//
// LEVEL. The "level" of a pixel is the tessellation level, as the control stage wrote it
// (gl_TessLevelOuter/Inner before any rounding), that governed its triangle: a triangle
// with a vertex on an outer edge of its patch belongs to that edge's strip and reads
// gl_TessLevelOuter[edge] (the edge holding most of its vertices; ties go to the lower edge
// index); a triangle with no vertex on an outer edge reads the inner level (quads: the
// larger of gl_TessLevelInner[0] and [1]).
//
// DETERMINISM. Every pass is a function of the pixel (or a deterministic reduction), so the
// result is byte-identical whatever the number of threads (oneTBB: the caller's arena or
// tbb::global_control).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "tessref/raster.h"
#include "tessref/pipeline.h"
#include "tessref/shading.h"
#include "tessref/tessellator.h"

namespace tessref {

// ---- rendering -------------------------------------------------------------------------

enum class RenderMode : std::uint8_t {
    fill,                 // filled triangles
    wireframe,            // glPolygonMode(GL_FRONT_AND_BACK, GL_LINE): the fragment shader
                          // runs on the lines' pixels, depth LESS among the lines
    fill_with_wireframe,  // fill, then the lines in RenderShading::wireframe_colour where
                          // they are not behind the filled surface (see render_scene)
};

struct RenderOptions {
    // Image size; {0, 0}: the camera's viewport. A size replaces the camera's viewport
    // (aspect ratio and the PN control stage's pixel measure follow it, as they would in an
    // application whose window had that size).
    glm::ivec2 size{0, 0};
    RenderMode mode = RenderMode::fill;
    Precision precision = Precision::gpu;   // of the pipeline (the rasterizer is float)
    MathMode math = MathMode::exact;        // PipelineOptions::math
    // Camera-relative evaluation (PipelineOptions::camera_relative, gpu precision only): the
    // pipeline evaluates relative to the eye, and gl_Position = mvp * the eye-relative float
    // position with mvp the view-projection of the camera moved by -origin (built in double,
    // rounded to float; RenderResult::mvp). render_surface() does so whenever the pipeline
    // result carries relative positions.
    bool camera_relative = false;
    // Keep the tessellated surface in RenderResult::pipeline (its mesh and face normals, for
    // pixel_provenance's vertices or a capture). Without it, a filled render of a scene whose
    // surface can be streamed (not geomipmapped, no smooth normals) evaluates, rasterizes and
    // resolves a batch of patches at a time and never holds the whole surface: its memory is
    // bounded by the image and the batch, not by the triangle count, and the pipeline
    // result keeps the levels only. The image and every per-pixel buffer are the same
    // either way (tests/test_render_stream.cpp).
    bool keep_surface = false;
    // Fill RenderResult's provenance buffers patch_id, tess_coord, barycentric and level.
    // Off, they stay empty and the image, depth and triangle ids are the same: the resolve
    // then reads only what the fragment stage needs of each triangle (a PNG needs no more; on
    // the 64 x 64-patch level-16 bench terrain the provenance reads were a third of the
    // resolve's time, mostly cache misses into the patches' tess coords and ids), and the
    // streamed render keeps no whole-image weights at all (the rasterizer's per tile, for
    // one draw: a 12-byte buffer a pixel less to clear). pixel_provenance needs them. The
    // ray-traced and user-fragment renders fill them either way.
    bool provenance = true;
    // Keep the image only as the 8-bit RGBA codes a PNG or TIFF holds (RenderResult::rgba8,
    // to_rgba8's bytes) and leave the float RenderResult::colour empty: 4 bytes a pixel to
    // clear and fill instead of 16 plus the conversion. The streamed render converts each
    // pixel as it shades it; the other renderers convert their float image at the end. Every
    // other buffer is the same either way. An EXR, compare_images and pixel_provenance need
    // the float colour.
    bool colour8 = false;
    // Called from the calling thread with a stage name and the fraction of it done; may be
    // empty.
    std::function<void(std::string_view stage, double fraction)> progress;
};

struct RenderStats {
    std::uint64_t triangles = 0;        // tessellated triangles drawn
    std::uint64_t vertices = 0;
    std::uint64_t covered_pixels = 0;   // pixels with a visible surface
    RasterStats raster{};               // of the fill (or line) pass
    // Wall-clock per phase (informative only). The streamed render evaluates each batch's
    // chunks in the draw's own tasks: its pipeline time is the stream's passes 1 to 3 (levels,
    // patterns), and the evaluation counts as raster time.
    double seconds_pipeline = 0.0;
    double seconds_raster = 0.0;
    double seconds_shade = 0.0;
};

constexpr std::uint32_t kNoPixelId = kNoTriangle;  // patch/triangle id of an empty pixel

struct RenderResult {
    int width = 0;
    int height = 0;
    RenderShading shading{};           // the scene's, as used
    SceneCamera camera{};              // the camera as used (viewport = image size)
    Domain domain = Domain::quads;     // the generator's domain (for the level rule)
    glm::mat4 mvp{1.0f};               // float(camera.view_projection()), the shaders' mvp; camera-
                                       // relative: of the camera moved by -pipeline->origin
    // Per pixel (row 0 on top):
    std::vector<glm::vec4> colour;     // the fragment stage's output, unclamped; background
                                       // where nothing is visible (empty with colour8)
    std::vector<glm::u8vec4> rgba8;    // with RenderOptions::colour8 only: colour's unorm8 codes
    std::vector<float> depth;          // window z in [0, 1]; 1 where nothing is visible
    std::vector<std::uint32_t> patch_id;     // kNoPixelId where nothing is visible
    std::vector<std::uint32_t> triangle_id;  // index into pipeline.mesh.triangles
    std::vector<glm::vec3> tess_coord;       // interpolated gl_TessCoord
    std::vector<glm::vec3> barycentric;      // perspective-correct weights of the triangle
                                             // (RenderOptions::provenance only)
    std::vector<float> level;                // see LEVEL above; NaN where nothing is visible
    // What produced it (kept for pixel_provenance; null for a ray-traced image). A streamed
    // render (RenderOptions::keep_surface off) keeps the levels here, an empty mesh, and the
    // stream, from which pixel_provenance evaluates the one triangle it names.
    std::shared_ptr<const PipelineResult> pipeline;
    std::shared_ptr<const PatchStream> stream;
    RenderStats stats{};

    std::size_t index(int x, int y) const {
        return static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
               static_cast<std::size_t>(x);
    }
};

// Renders the scene. Throws tessref::Error when the scene has no [camera], the size is
// outside 1..16384, or the pipeline refuses the scene.
//
// fill_with_wireframe: the lines are rasterized into a buffer of their own (depth LESS among
// lines); a line pixel is drawn over the filled image when nothing is filled there or its
// depth is <= the filled depth plus the filled triangle's depth slope at that pixel (the
// larger of its window-z change over one pixel in x and in y) plus 2^-20: the offset
// glPolygonOffset(1, units) would give the filled pass, so that edges on the visible surface
// show and edges behind it do not.
//
// A scene whose [shaders] (or `--shader frag=FILE`) names a fragment shader other than its
// shading model's twin (user_fragment_shader) is shaded by that shader on the CPU's SPIR-V
// interpreter (src/render/user_fragment.cpp): fill mode, gpu precision, without
// camera-relative evaluation; Error otherwise.
RenderResult render_scene(const Scene& scene, const RenderOptions& options = {});

// The scene's fragment shader that render_scene runs instead of its shading model: the
// [shaders] fragment entry whose text is not the model's GLSL twin; nullptr when none.
const StageShader* user_fragment_shader(const Scene& scene);

// What render_scene does after the pipeline: renders a surface that run_pipeline(scene)
// produced (with the camera's viewport set to the image size when options.size is given,
// as render_scene runs it). Lets a caller render one tessellation several times (modes,
// benchmarks) without running the pipeline again. Throws tessref::Error when `pipeline` is
// null or inconsistent with the scene.
RenderResult render_surface(const Scene& scene, std::shared_ptr<const PipelineResult> pipeline,
                            const RenderOptions& options = {});

// ---- the ground truth ------------------------------------------------------------------

struct RaytraceStats {
    std::uint64_t triangles = 0;     // of the full-resolution surface
    std::uint64_t vertices = 0;
    int grid_columns = 0;            // vertex columns and rows of the surface
    int grid_rows = 0;
    std::uint64_t covered_pixels = 0;
};

// The same camera and fragment stage on the full-resolution height field, ray-traced with
// Embree. Terrain scenes only ([domain]); throws tessref::Error for a mesh scene.
//
// The surface: the height the evaluation shader would compute at level "infinity", i.e.
// the height map sampled at mip level 0 (in double: the texel values exactly, bilinear in
// between), as TWO TRIANGLES PER TEXEL QUAD. Vertex columns lie at every texel centre inside
// the grid's extent plus the extent's two borders (rows likewise): between texel centres
// GL_LINEAR sampling is bilinear, and the two triangles of each quad (split along the
// diagonal from its (low u, low v) corner to its (high u, high v) corner) agree with it at
// the four corners; in the half-texel border strips clamp-to-edge makes the height constant
// across the strip, so there the triangles are exact. Lab 4's mip-matched heights are not
// modelled: the ground truth is mip 0 everywhere.
//
// Fragment inputs at a hit: worldPosition = the hit point; texCoord = the evaluation model's
// mapping of the hit's ground coordinates (thesis xy / scale_xy, COSC422 the extent, lab 4
// xz / scale_xy + offset); derivatives per 2x2 quad as in render_scene, from the quad's
// other rays intersected with the plane of the hit triangle; normal = the scene's geometry
// stage evaluated at the hit instead of at a tessellated vertex: normal_map -> the normal map
// sampled at texCoord (NormalFromTexture), height_field -> lab 4 appendix A at mip 0, face ->
// the hit triangle's normal, smooth -> the area-weighted vertex normals of the surface
// interpolated; no [geometry] -> none, as in render_scene (terrain evaluation gives none).
// patch_id/triangle_id/tess_coord/level are kNoPixelId/texel triangle index/0/NaN.
RenderResult raytrace_scene(const Scene& scene, const RenderOptions& options = {},
                            RaytraceStats* stats = nullptr);

// ---- provenance -----------------------------------------------------------------------

struct PixelProvenance {
    int x = 0, y = 0;                  // image pixel (row 0 on top)
    int window_x = 0, window_y = 0;    // GL window coordinates (y up)
    bool covered = false;              // false: background, the fields below are defaults
    glm::vec4 colour{0.0f};
    float depth = 1.0f;                // window z
    std::uint32_t patch_id = kNoPixelId;
    std::uint32_t triangle_id = kNoPixelId;
    std::array<std::uint32_t, 3> vertices{};      // mesh vertex indices of the triangle
    std::array<glm::vec3, 3> vertex_tess_coords{};
    glm::vec3 barycentric{0.0f};
    glm::vec3 tess_coord{0.0f};
    float level = 0.0f;                // see LEVEL
    std::string level_source;          // "outer[2]" or "inner"
    TessLevels patch_levels{};         // what the control stage wrote for the patch
    glm::dvec3 world_position{0.0};    // the triangle's positions interpolated
    std::optional<glm::dvec3> normal;  // when the mesh has normals
    std::optional<glm::dvec2> uv;      // when the mesh has texture coordinates
};

// The provenance of pixel (x, y) of a rendered image. Throws tessref::Error (key "pixel")
// when (x, y) is outside the image.
PixelProvenance pixel_provenance(const RenderResult& result, int x, int y);

// The level a triangle reads (see LEVEL) and where it comes from ("outer[e]" / "inner").
float triangle_level(const PipelineResult& pipeline, Domain domain, std::uint32_t triangle,
                     std::string* source = nullptr);

// ---- the ground under a point (lab 4's camera collision) -----------------------------

// Lab 4 keeps its camera above the terrain by reading the height map under the camera. What
// the viewer sees, though, is the tessellated surface the current levels produce, which lies
// above or below the height map between its vertices. ground_height() answers both at a
// ground point, so the difference (how far a camera that trusts the height map can sink
// into, or float above, the drawn surface) can be measured.
struct GroundHeight {
    glm::dvec2 ground{0.0};         // the point: (x, y) on plane xy, (x, z) on plane xz
    double height_map = 0.0;        // the full-resolution surface there (the ray-traced
                                    // truth's: mip 0 in double, bilinear, times scale_z)
    bool on_surface = false;        // false: no tessellated triangle covers the point
    double tessellated = 0.0;       // the tessellated surface's height there (when on_surface)
    std::uint32_t patch_id = kNoPixelId;
    std::uint32_t triangle_id = kNoPixelId;
    TessLevels patch_levels{};
    double difference() const { return tessellated - height_map; }  // when on_surface
};

// The heights at `ground` of the scene's height map and of `pipeline`'s tessellated surface
// (the first triangle, in triangle order, whose ground projection holds the point,
// interpolated linearly, as the rasterizer would). Terrain scenes (a geomipmapped one's
// height map is bilinear between its samples, ground_truth.h); throws tessref::Error for a
// mesh scene and a point outside the terrain's extent.
GroundHeight ground_height(const Scene& scene, const PipelineResult& pipeline, glm::dvec2 ground);

// ---- images ----------------------------------------------------------------------------

// The colour map of the level heat map: log2(level) over [0, 6] (levels 1..64) through
// blue, cyan, green, yellow, red; levels below 1 read blue, above 64 red; NaN black.
glm::vec3 level_heat_colour(float level);

// GL's unorm8 conversion of the colour (clamp to [0, 1], * 255, round to nearest), RGBA,
// row 0 on top: RenderResult::rgba8's bytes where the render kept only those (colour8).
std::vector<std::uint8_t> to_rgba8(const RenderResult& result);

enum class ImageFormat : std::uint8_t { png, tiff, exr };
// From the output path's extension: .png, .tif/.tiff, .exr (any case). Throws tessref::Error
// naming the path otherwise.
ImageFormat image_format_from_path(const std::string& path);

// The arbitrary output variables an EXR can carry besides RGBA.
struct AovSelection {
    bool depth = false;      // channel "Z": window depth (1 = nothing)
    bool patch = false;      // "patch_id": the patch id as a float, -1 = nothing
    bool triangle = false;   // "triangle_id": likewise (exact up to 2^24 triangles)
    bool tesscoord = false;  // "tess_coord.u", "tess_coord.v", "tess_coord.w"
    bool level = false;      // "level" (the value, NaN = nothing) and the heat map
                             // "level_heat.R", "level_heat.G", "level_heat.B"
    bool any() const { return depth || patch || triangle || tesscoord || level; }
};
// A PNG takes `level` alone: the level heat map as a picture, its legend in a band below
// (write_image). Every other selection needs an EXR.
inline bool aovs_as_png(const AovSelection& a) { return a.level && !a.depth && !a.patch && !a.triangle && !a.tesscoord; }
// Parses "depth,patch,triangle,tesscoord,level" (any subset, any order). Throws
// tessref::Error (key "--aov") naming an unknown item.
AovSelection parse_aovs(std::string_view list);

// Writes the image to `path` in `format` (png by tessref itself, tiff and exr through
// OpenImageIO): png and tiff as 8-bit RGBA
// (to_rgba8); exr as 32-bit float R, G, B, A (the unclamped colour) plus the selected AOV
// channels. AOVs need exr (an Error otherwise). The file at `path` is written directly:
// callers that must not leave a partial file write to a temporary name and rename.
void write_image(const RenderResult& result, const std::string& path, ImageFormat format,
                 const AovSelection& aovs = {});

// The peak memory, in bytes, that rendering (or ray tracing) an image of `size` and writing
// it as `format` with `aovs` needs beyond the scene and its tessellated surface, for
// refusing with require_memory() before the pipeline runs. From measured peaks (render.cpp).
std::uint64_t estimate_render_memory(glm::ivec2 size, RenderMode mode, bool raytrace, ImageFormat format,
                                     const AovSelection& aovs);

// Colour difference of two renders of the same size (Error otherwise): compare_images() of
// tessref/compare.h over the R, G, B channels of the colours clamped to [0, 1] (what a
// unorm8 framebuffer holds, before its quantization; NaN as 0): its RMSE and max error,
// plus the pixels covered in one render only. For the pass/fail rule with a threshold and
// a position deviation, call compare.h directly.
struct ImageDifference {
    double rmse = 0.0;
    double max_abs = 0.0;
    std::uint64_t coverage_mismatch = 0;
    std::uint64_t pixels = 0;
};
ImageDifference compare_images(const RenderResult& a, const RenderResult& b);

}  // namespace tessref
