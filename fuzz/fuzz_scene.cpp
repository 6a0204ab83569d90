// fuzz/fuzz_scene.cpp — the scene loader (TOML, src/scene/scene.cpp), [shading]
// (src/scene/shading_load.cpp) included.
//
// The text is loaded as if it were fuzz/scene_env/scenes/fuzz.toml, so the relative paths
// of the shipped scenes ("../heightmaps/thesis-island.pgm", "../meshes/cube.off", ...)
// resolve to small copies of the shipped data there: the seeds load completely, quickly,
// and the fuzzer reaches the checks that come after the images are loaded.
#include "fuzz_common.h"
#include "tessref/prepare.h"
#include "tessref/scene.h"

#ifndef TESSREF_FUZZ_SCENE_ENV
#error "TESSREF_FUZZ_SCENE_ENV must name fuzz/scene_env"
#endif

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    using namespace tessref;
    tessref_fuzz::init_limits();
    const std::string text(tessref_fuzz::as_text(data, size));
    tessref_fuzz::expect_only_tessref_errors([&] {
        const Scene scene = load_scene_from_string(text, TESSREF_FUZZ_SCENE_ENV "/scenes/fuzz.toml");
        // What every command does next with a loaded scene, short of running the pipeline.
        (void)scene.patch_count();
    });
    return 0;
}
