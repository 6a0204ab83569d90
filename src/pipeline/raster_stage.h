// src/pipeline/raster_stage.h — the vertices the rasterizer draws, as the GL pipeline's last
// stage before it writes them: what a user's fragment shader reads (src/render/user_fragment.cpp).
#pragma once

#include <vector>

#include "tessref/control.h"
#include "tessref/mesh.h"
#include "tessref/scene.h"
#include "tessref/shader.h"

namespace tessref::pipeline {

// A user's fragment shader reads what the last stage before the rasterizer wrote: every
// triangle's three corners of `mesh` (run_pipeline's result for `scene`, in `math`) through
// the scene's stages on the interpreter (the user's files and the twins), with the uniforms
// of the GL backend's draw, in the order GL draws them (the primitive generator's). Throws
// tessref::Error for a geomipmapped terrain, and the interpreter's errors.
struct RasterStageCorners {
    std::vector<shader::ShaderVertex> corners;  // triangle t's at 3t, 3t + 1, 3t + 2
    bool flipped = false;  // mesh triangle t is GL's with its corners 1 and 2 swapped
};
RasterStageCorners raster_stage_corners(const Scene& scene, const SurfaceMesh& mesh, MathMode math);

}  // namespace tessref::pipeline
