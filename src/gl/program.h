// src/gl/program.h — building GL programs from shader files (private to src/gl/): the one
// place that reads shader sources, compiles and links them and turns the driver's info log
// into a tessref::Error naming the file, its line and the stage. The tess-coord capture
// (tess_capture.cpp) and the scene renderer (scene_render.cpp) both build through it.
#pragma once

#include <string>
#include <vector>

#include "gl/gl_api.h"
#include "tessref/error.h"

namespace tessref::gl {

// tessref::data_dir() (common/data_dir.h): shaders are read at run time from its shaders/.
std::string shader_data_dir();
// The text of data/shaders/<name>; throws tessref::Error naming the path when unreadable.
std::string read_shader(const std::string& name);

// One stage's source: a file (path set: a twin of data/shaders/ or a user's file) or
// built-in text, with text inserted after the #version line and appended at the end.
struct StageSource {
    GLenum stage = 0;
    std::string path;    // the file as errors name it; empty for built-in text
    std::string origin;  // a user's file: the flag or scene key that named it, as typed
    std::string text;    // the source (read from the file when path is set)
    std::string prefix;  // inserted right after the #version line
    std::string suffix;  // appended after the text
};

// The stage as [shaders] and --shader name it: "vertex", "tess_control", ...
const char* stage_name(GLenum stage);

// The first "0:LINE(COLUMN)" of a Mesa info log (0 when there is none).
int log_line(const std::string& log);

// Compiles one stage. The file's line numbers are kept (a #line directive follows the
// inserted prefix), so the log's lines are the file's. Throws tessref::Error with the
// driver's log, Where = the file and the log's first line.
GLuint compile(GlFunctions& gl, const StageSource& source);

// Compiles and links the stages, with the transform feedback varyings (interleaved) when
// any. Throws tessref::Error with the driver's log and every stage's file; `what` names the
// program in the message ("the scene program", ...).
GLuint link(GlFunctions& gl, const std::vector<StageSource>& stages, const std::vector<const char*>& varyings,
            const std::string& what);

}  // namespace tessref::gl
