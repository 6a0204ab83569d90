// src/image/oiio_module.h — the OpenImageIO module (tessref_oiio.so), loaded on first use.
#pragma once

#include <string>
#include <vector>

#include "image/oiio_module_abi.h"

namespace tessref::image {

// The module's functions, loading it on the first call (thread-safe; it stays loaded).
// `why` says what needed it ("reading texture a.exr"), for the error at `path` when it
// cannot be loaded: a tessref::Error naming every place searched, first of
//  1. $TESSREF_OIIO_MODULE when set (the module file, used as given: then the only place);
//  2. <directory of the running executable>/TESSREF_BIN_TO_MODULE/tessref_oiio.so — the
//     installed layout (bin/tessref, lib/tessref/tessref_oiio.so), wherever the prefix moved;
//  3. <directory of the running executable>/tessref_oiio.so — the build tree;
//  4. $TESSREF_DATA_DIR/TESSREF_DATA_TO_MODULE/tessref_oiio.so when TESSREF_DATA_DIR is set —
//     a program linking the installed libtessref.a, pointed at the installed data.
const tessref_oiio_api& oiio_module(const std::string& why, const std::string& path);

// The places oiio_module() looks, in order (for messages and tests).
std::vector<std::string> oiio_module_candidates();

}  // namespace tessref::image
