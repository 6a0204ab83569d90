// The paths tests/build_paths.h declares, from CMakeLists.txt's compile definitions: the one
// file compiled again in every clone (see the header).
#include "build_paths.h"

namespace tessref::build_paths {
const char* const exe = TESSREF_PATH_EXE;
const char* const source_dir = TESSREF_PATH_SOURCE_DIR;
const char* const data_dir = TESSREF_PATH_DATA_DIR;
const char* const oiio_module_file = TESSREF_PATH_OIIO_MODULE_FILE;
const char* const build_dir = TESSREF_PATH_BUILD_DIR;
const char* const cmake_command = TESSREF_PATH_CMAKE_COMMAND;
const char* const cmake_generator = TESSREF_PATH_CMAKE_GENERATOR;
const char* const cmake_make_program = TESSREF_PATH_CMAKE_MAKE_PROGRAM;
const char* const cxx_compiler = TESSREF_PATH_CXX_COMPILER;
}  // namespace tessref::build_paths
