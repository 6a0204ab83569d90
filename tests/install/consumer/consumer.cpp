// Uses an installed tessref through its public headers only: the primitive generator, a
// shipped scene loaded from the installed share/tessref/, the GL backend (llvmpipe), and an
// EXR image (OpenImageIO through the installed module).
// Exit 0 and "consumer: ok" when every count matches; the expected counts come from the
// tessellation rules and the scene files, not from a run of tessref.
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <string>

#include <tessref/compare.h>
#include <tessref/error.h>
#include <tessref/gl_backend.h>
#include <tessref/pipeline.h>
#include <tessref/prepare.h>
#include <tessref/tessellator.h>

namespace {

int failures = 0;

void expect(const char* what, std::size_t got, std::size_t want) {
    std::printf("%s: %zu (expected %zu)\n", what, got, want);
    if (got != want) ++failures;
}

}  // namespace

int main() {
    try {
        // Equal spacing, every level 4 on quads: a 4 x 4 grid of quads, two triangles each.
        tessref::TessSettings quads;
        quads.domain = tessref::Domain::quads;
        quads.spacing = tessref::Spacing::equal;
        tessref::TessLevels four;
        four.outer = {4.0f, 4.0f, 4.0f, 4.0f};
        four.inner = {4.0f, 4.0f};
        expect("quads 4/4 triangles", tessref::tessellate(quads, four).primitive_count(), 32);

        // thesis-constant-1: [domain] patches = [16, 16], [control] level 1 on quads (the
        // minimal patch: two triangles each) -> 256 patches, 512 triangles.
        const std::string data = CONSUMER_DATA_DIR;
        const tessref::Scene terrain = tessref::load_scene(data + "/scenes/thesis-constant-1.toml");
        expect("thesis-constant-1 patches", terrain.patch_count(), 256);
        expect("thesis-constant-1 triangles at level 1", tessref::run_pipeline(terrain).mesh.triangles.size(), 512);

        // pn-triangles: one patch per mesh triangle, read through OpenMesh; the OFF headers
        // say 20 (icosahedron) + 12 (cube) + 72 (bump) faces.
        const tessref::Scene pn = tessref::load_scene(data + "/scenes/pn-triangles.toml");
        expect("pn-triangles patches", pn.patch_count(), 20 + 12 + 72);

        // The real generator (OSMesa, llvmpipe) agrees with the count; its shaders come from
        // $TESSREF_DATA_DIR, since this program does not live in the installed bin/.
        tessref::gl::Context context = tessref::gl::Context::create();
        expect("llvmpipe quads 4/4 triangles", tessref::gl::capture_pattern(context, quads, four).primitive_count(), 32);

        // An EXR written and read back: OpenImageIO, through the installed module
        // lib/tessref/tessref_oiio.so, which the library finds from $TESSREF_DATA_DIR.
        tessref::FloatImage picture;
        picture.width = 2;
        picture.height = 1;
        picture.channels = 3;
        picture.channel_names = {"R", "G", "B"};
        picture.samples = {0.25f, 0.5f, 1.5f, -1.0f, 2.0f, 0.125f};
        const char* tmp = std::getenv("TMPDIR");
        const std::string exr = std::string(tmp && *tmp ? tmp : "/tmp") + "/tessref-consumer-" +
                                std::to_string(static_cast<long>(::getpid())) + ".exr";
        tessref::write_float_image(picture, exr);
        const tessref::FloatImage back = tessref::read_float_image(exr);
        std::remove(exr.c_str());
        expect("EXR samples read back unchanged", back.samples == picture.samples ? 1 : 0, 1);
    } catch (const tessref::Error& e) {
        std::fprintf(stderr, "consumer: error: %s\n", e.message().c_str());
        return 2;
    }
    if (failures != 0) return 1;
    std::printf("consumer: ok\n");
    return 0;
}
