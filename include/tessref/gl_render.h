// tessref/gl_render.h — a scene drawn through its GLSL twins on llvmpipe (`tessref gl`),
// on a gl_backend.h context.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <set>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "tessref/capture.h"
#include "tessref/gl_backend.h"
#include "tessref/scene.h"

namespace tessref {
struct PipelineResult;  // pipeline.h
}  // namespace tessref

namespace tessref::shader {
class Module;
}  // namespace tessref::shader

namespace tessref::gl {

// render_scene() draws a scene with the shaders of data/shaders/ on llvmpipe: the vertex and
// evaluation shader of the [evaluation] model, the control shader of the [control] model (a
// constant control stage: a pass-through control shader writing the level, or none when the
// evaluation shader reads gl_in directly, with GL_PATCH_DEFAULT_*_LEVEL set), the geometry
// shader of [geometry] where the model has one (thesis normal_map, cosc422 face; lab 4's
// height-field normals are computed in its evaluation shader), and the fragment shader of
// [shading]. The evaluation twin's layout(...) in; line is replaced by the scene's
// [generator] settings, as the CPU pipeline uses them. Uniforms come from the scene's
// settings structs (one function per model, scene_render.cpp), textures are uploaded from
// the very Texture objects the CPU samples (same format and codes, glGenerateMipmap,
// clamp-to-edge, GL_LINEAR / GL_LINEAR_MIPMAP_LINEAR). Camera and image size as
// `tessref render` (render.h): --size replaces the viewport.
//
// The CPU pipeline runs first, in llvmpipe's math mode (SceneRenderOptions::math): its
// per-patch triangle counts size the draws (at most max_primitives_per_draw predicted
// primitives per draw, at least one patch) and every draw's GL_PRIMITIVES_GENERATED is held
// against its prediction. A draw that disagrees is named in batch_failure (llvmpipe
// corrupts large tessellated draws silently; a level computed differently by a user's
// shader shows here too); the image is still drawn, and the capture is taken (with or
// without SceneRenderOptions::capture) to list the patches whose levels or triangle counts
// differ (differences).
//
// User shaders (the scene's [shaders], `tessref gl --shader STAGE=FILE`): a user's GLSL file
// takes the place of one stage's twin, or is added where the models have no such stage
// (a geometry shader without [geometry], a control shader where the constant stage has
// none). Everything else stays: the other stages, the uniforms and the textures. The CPU
// pipeline that predicts the counts runs the user's vertex, control and evaluation shaders
// through its interpreter (pipeline.h, src/pipeline/user_program.cpp), so a control shader
// that computes other levels than the model is predicted. A user's evaluation shader keeps
// its own layout(...) in; line (it is what is under test; the CPU tessellates as
// [generator]), so a layout that tessellates differently, or levels llvmpipe computes
// otherwise than the interpreter, are reported as above, the message naming the user's files. The contract a user's shader is held to is the twins'
// interface: the uniform names and types, the sampler bindings, the vertex attributes and
// the blocks between the stages (below; docs/CLI.md, "Debugging your own shader"); a
// uniform it leaves out is not set, one it declares with another type is an error.
//
// THE CONTRACT, per model (the twins in data/shaders/ are the reference text; the uniforms
// are set by src/pipeline/stage_uniforms.cpp, for the GL backend and the CPU's interpreter,
// and the fragment stage's by src/gl/scene_render.cpp). A stage talks to its
// neighbours through these blocks (matched by block name and location 0) and attributes:
//   thesis   attribute 0 vec4 position (the corner, z = 0);
//            vert -> tesc VertexData { vec4 vPosition; }, tesc -> tese ControlData
//            { vec4 tcPosition; } (4 vertices), tese -> geom EvaluationData { vec2
//            textureCoordinate; }, geom -> frag GeometryData { vec3 gNormal; vec2
//            gTextureCoordinate; }; uniforms float scaleXY, scaleZ; mat4 mvp; mat3
//            normalMatrix; control: float tessellationLevel, distanceLimit, distanceDivisor,
//            normalAngleThreshold, {normal,texture,distance,constant}TessellationWeight;
//            vec3 cameraPosition; int thesisFactor; constant control: float constantLevel
//   cosc422  attribute 0 vec4 position, handed on as gl_Position (tesc/tese read gl_in);
//            tese -> geom EvaluationData { vec3 worldPosition; vec2 texCoord; }, geom ->
//            frag GeometryData { vec3 faceNormal; vec2 texCoord; }; uniforms mat4 mvpMatrix,
//            mvMatrix; float xMin, xMax, zMin, zMax, heightScale; int levelSpace
//   lab4     attribute 0 vec4 position; VertexData and ControlData as thesis; patch outputs
//            of the control stage at locations 1..4: float maxLogTessellationLevel; vec4
//            logOuter; float logInner; vec4 logCorner; tese -> frag EvaluationData { vec3
//            worldPosition; vec3 normal; vec2 texCoord; }; uniforms mat4 mvp; float
//            horizontalScale, verticalScale, gridStep; vec2 texCoordOffset; control: vec3
//            cameraPosition; float firstZoneEnd, zoneGrowth, maxLevel, minLevel; int edgeRule
//   pn       attributes 0 vec3 v3VertexPos, 1 vec3 v3VertexNormal, 2 vec2 v2VertexUV;
//            vert -> tesc VertexData { vec3 v3Position; vec3 v3Normal; vec2 v2UV; }, tesc ->
//            tese PatchVertex { ... } (3 vertices) and patch vec3 v3P111 at location 6, tese
//            -> frag EvaluationData { vec3 v3PositionOut; vec3 v3NormalOut; vec2 v2UVOut; };
//            uniforms mat4 m4Transform, m4ViewProjection; vec2 v2Resolution; float
//            fInfluence; int normalMode; bool watertightEdges, flatEdgesAtLevel1
//   samplers heightMap 0, tessellationMap 1, normalMap 2, the fragment twins' textures
//            4.. in the order of shading.h's sampler_names (the thesis's diffuse is 4)
//   fragment uniforms as the [shading] model's twin declares them (shading.h), output at
//            location 0; flat: vec4 colour; depth: int windowMapping, double nearPlane,
//            farPlane.
// --capture wraps the stages before rasterization and reads the twins' outputs (thesis:
// gl_Position with mvp = identity; cosc422, lab4: evaluationOut.worldPosition; pn:
// evaluationOut.v3PositionOut; normals: geometryOut.gNormal / .faceNormal,
// evaluationOut.normal / .v3NormalOut), so a user's stage there must declare them too.
struct SceneRenderOptions {
    glm::ivec2 size{0, 0};  // {0, 0}: the camera's viewport
    bool wireframe = false; // glPolygonMode(GL_FRONT_AND_BACK, GL_LINE)
    bool capture = false;   // also record every evaluated vertex by transform feedback
    std::size_t max_primitives_per_draw = 32768;  // `tessref gl --max-primitives-per-draw N`
    // Test hook: the prediction of this draw (0-based) is made one too high, so that the
    // check must fail there. -1: none.
    long long corrupt_prediction_of_batch = -1;
    // User shaders (--shader), each in place of the scene's [shaders] entry of its stage.
    std::vector<StageShader> shaders;
    // The CPU pipeline of the scene at the image's viewport, when the caller has run it
    // (render_scene_isolated() runs it in the parent); null: render_scene() runs it.
    std::shared_ptr<const PipelineResult> pipeline;
    double pipeline_seconds = 0.0;  // how long that took, for SceneRenderStats
    // The math mode of the CPU pipeline that predicts the counts (control.h MathMode):
    // llvmpipe's approximations, so that its levels are the driver's bit for bit.
    MathMode math = MathMode::llvmpipe;
    // render_scene_isolated(): work for this process while the child draws (run_isolated's
    // `meanwhile`, src/common/isolated.h), after the pipeline above has run. It may use
    // oneTBB; it must not touch what the child answers into.
    std::function<void()> meanwhile;
    // With `capture`: each capture draw's vertices are handed to this, draw by draw in patch
    // order, instead of being kept in SceneRender::capture (which stays empty), so that a
    // caller that compares the capture as it comes never holds it whole. render_scene_
    // isolated() calls it here in the parent, as the child's draws arrive (after
    // `meanwhile`). A draw whose count differs stops the capture (SceneRender::batch_failure):
    // what was handed on by then is part of a capture that does not count. Where a drawing
    // draw's count already differed, the capture is kept whole as without a sink, to find
    // the patches that differ, and nothing is handed on.
    std::function<void(std::span<const CapturedVertex>)> capture_sink;
    // render_scene_isolated(): false lets go of the CPU pipeline here as soon as the child
    // has its copy (before `meanwhile`), for a caller that has no use for
    // SceneRender::pipeline (then null) and needs the memory while the child draws.
    bool return_pipeline = true;
};

// A patch whose levels or triangle count differ between the CPU pipeline and llvmpipe.
struct PatchDifference {
    std::size_t patch = 0;
    std::uint64_t cpu_triangles = 0;
    std::uint64_t gl_triangles = 0;   // captured by transform feedback
    TessLevels cpu_levels{};
    TessLevels gl_levels{};           // as llvmpipe's evaluation shader read them
    bool gl_levels_known = false;     // false: llvmpipe emitted nothing for the patch
};

// SceneRender::capture: one CapturedVertex (tessref/capture.h) per vertex of every
// primitive, as transform feedback recorded it (three per triangle, in the order the
// pipeline emitted them); patch_id is gl_PrimitiveID of the evaluation shader plus the
// draw's first patch, levels are gl_TessLevelOuter/Inner as the evaluation shader read them.

struct SceneRenderStats {
    std::uint64_t triangles = 0;  // GL_PRIMITIVES_GENERATED summed over the draws
    std::size_t draws = 0;
    double seconds_pipeline = 0.0;  // the CPU pipeline (predictions)
    double seconds_gl = 0.0;        // the GL draws, the read-back included
    double seconds_capture = 0.0;  // the capture draws and read-back, not the time spent in capture_sink
};

struct SceneRender {
    int width = 0;
    int height = 0;
    RenderShading shading{};
    std::vector<glm::vec4> colour;  // row 0 on top (OSMesa's rows flipped), unclamped float
    std::vector<CapturedVertex> capture;  // with SceneRenderOptions::capture
    // Non-empty: a draw's primitive count differed from the prediction (every such draw
    // named). The image is still drawn, and the capture taken to find the patches:
    std::string batch_failure;
    std::vector<PatchDifference> differences;  // with batch_failure: the patches that differ
    std::shared_ptr<const PipelineResult> pipeline;  // the CPU pipeline the counts came from
    std::vector<StageShader> user_shaders;  // the user's files in place of twins, vertex .. fragment
    // render_scene_isolated(): unset_uniform_warnings() of each user's stage.
    std::vector<std::string> warnings;
    SceneRenderStats stats{};
};

// Throws tessref::Error on a scene the GL backend cannot draw (no camera, a stage
// combination without a GLSL twin), an unreadable shader file (a user's: Where is its
// scene key or flag), a shader that does not compile or link (the driver's log and the
// stage; Where: the file and, from the log, the line), a user's shader that declares a
// twin's uniform with another type, or a GL error.
SceneRender render_scene(Context& context, const Scene& scene, const SceneRenderOptions& options = {});

// render_scene() as `tessref gl` and `tessref golden verify` run it: the CPU pipeline here,
// the context and every GL call in a child process with its own memory and time limits
// (src/common/isolated.h: the memory budget of --max-memory / TESSREF_MAX_MEMORY, and
// TESSREF_GL_TIME_LIMIT seconds, default 600), so that a user's shader that exhausts
// memory, loops or crashes the driver is an Error naming the shader and the stage, never
// the end of tessref. SceneRender::pipeline is the pipeline run here.
struct IsolatedRender {
    SceneRender render;
    std::string renderer;  // GL_RENDERER of the child's context
};
IsolatedRender render_scene_isolated(const Scene& scene, const SceneRenderOptions& options = {});

// render_scene_isolated() in two halves (isolated.h's IsolatedChild): start runs the CPU
// pipeline here and starts the child, which draws at once; finish() runs options.meanwhile,
// hands the capture to options.capture_sink and returns the render. Whatever those two
// functions use must live until finish(). A render not finished (destroyed, an exception
// on the way) has its child killed and reaped. Start only while no other thread of this
// process runs work (the child is forked).
class PendingRender {
public:
    PendingRender(PendingRender&&) noexcept;
    PendingRender& operator=(PendingRender&&) noexcept;
    ~PendingRender();
    IsolatedRender finish();  // once only

    struct State;

private:
    explicit PendingRender(std::unique_ptr<State> state);
    friend PendingRender start_render_scene_isolated(const Scene&, const SceneRenderOptions&);
    std::unique_ptr<State> state_;
};
PendingRender start_render_scene_isolated(const Scene& scene, const SceneRenderOptions& options = {});
// GL_RENDERER, from a context made in a child process as above.
std::string renderer_isolated();

// The uniforms tessref sets for `scene`, by name, as the GLSL twins declare them: what the
// GL backend sets with glUniform* (and what a CPU run of a user's stage is to be given).
std::set<std::string> uniforms_set(const Scene& scene);
// One warning per loose uniform `stage` declares (shader::Module::uniform_names()) that
// tessref does not set for `scene`, naming the uniform and the stage's file: it reads 0, so a
// misspelt name (scaleZZ for scaleZ) is a silently wrong picture. Likewise one per sampler
// (shader::Module::samplers()) at a texture unit to which tessref binds no texture for
// `scene`, naming the sampler and its unit: samplers are bound by unit, the twins'
// layout(binding = N), so a sampler's name does not matter and its unit does. For every
// place a user's stage is loaded.
std::vector<std::string> unset_uniform_warnings(const Scene& scene, const shader::Module& stage);

}  // namespace tessref::gl
