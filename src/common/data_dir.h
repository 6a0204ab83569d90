// src/common/data_dir.h — where tessref's run-time data (data/: shaders, scenes, height
// maps) lives, for a build-tree and an installed executable alike.
#pragma once

#include <string>

namespace tessref {

// The data directory, first of:
//  1. $TESSREF_DATA_DIR when set (used as given, even when it does not exist: errors then
//     name the files looked for inside it);
//  2. <directory of the running executable>/TESSREF_BIN_TO_DATA — "../share/tessref" for
//     the installed layout (bin/tessref, share/tessref/), wherever the prefix was moved;
//  3. <directory of the running executable>/tessref-data — the build tree's link to the
//     source data/ (CMake makes it; an installed tree has none).
// A candidate counts when it holds shaders/. Nothing is compiled in that points into the
// source tree, so an installed executable never reads it behind the user's back.
// Throws tessref::Error naming every place searched when none qualifies.
std::string data_dir();

}  // namespace tessref
