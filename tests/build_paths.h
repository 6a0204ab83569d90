// tests/build_paths.h — where this build put tessref and where the sources are, for every
// suite and benchmark (CMakeLists.txt includes this header into each of them with -include).
//
// The paths are compiled into one small file, tests/build_paths.cpp, and not into each suite
// as compile definitions. An absolute path on a suite's command line makes its object file
// differ between two clones of the repository, and ccache, which makes paths relative only in
// include and source arguments, then compiled every suite again in every new clone: CI's
// clean checkout spent most of its build on suites it had compiled before, some taking
// minutes each.
#pragma once

namespace tessref::build_paths {
extern const char* const exe;               // the tessref command of this build
extern const char* const source_dir;        // the repository's root
extern const char* const data_dir;          // the repository's data/
extern const char* const oiio_module_file;  // the OpenImageIO module of this build
extern const char* const build_dir;         // this build's directory
// The tools of this build, for the install suite's consumer project.
extern const char* const cmake_command;
extern const char* const cmake_generator;
extern const char* const cmake_make_program;
extern const char* const cxx_compiler;
}  // namespace tessref::build_paths

#define TESSREF_EXE (::tessref::build_paths::exe)
#define TESSREF_SOURCE_DIR (::tessref::build_paths::source_dir)
#define TESSREF_DATA_DIR (::tessref::build_paths::data_dir)
#define TESSREF_OIIO_MODULE_FILE (::tessref::build_paths::oiio_module_file)
#define TESSREF_BUILD_DIR (::tessref::build_paths::build_dir)
#define TESSREF_CMAKE_COMMAND (::tessref::build_paths::cmake_command)
#define TESSREF_CMAKE_GENERATOR (::tessref::build_paths::cmake_generator)
#define TESSREF_CMAKE_MAKE_PROGRAM (::tessref::build_paths::cmake_make_program)
#define TESSREF_CXX_COMPILER (::tessref::build_paths::cxx_compiler)
