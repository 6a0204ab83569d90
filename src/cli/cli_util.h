// src/cli/cli_util.h — helpers shared by every subcommand of `tessref`.
//
//  - numbers from the command line, validated over the whole text, errors naming the flag;
//  - output files written atomically (temporary name in the target's directory, renamed
//    into place on success, removed on failure: never a partial or stale file);
//  - progress on stderr, only when stderr is a terminal.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <memory>

#include <glm/glm.hpp>
#include <tbb/global_control.h>

#include "common/file_name.h"  // lowercase_extension
#include "tessref/control.h"
#include "tessref/error.h"
#include "tessref/scene.h"
#include "tessref/tessellator.h"

namespace CLI {
class App;
}

namespace tessref::cli {

// ---------------------------------------------------------------------------------------
// Numbers

// Parses one float from `text`, the whole text (surrounding spaces allowed): decimal with
// optional sign and exponent ("1", "-2.5", "1e9", "2.5e-3"), hexadecimal floats, and,
// case-insensitively, "nan", "inf", "infinity" with optional sign. A magnitude beyond
// float's range becomes +-inf, one below it becomes +-0 or a subnormal (as strtof does).
// Returns nullopt when the text is not a number.
std::optional<float> parse_float(std::string_view text);

// The same for a double (strtod: the same forms as parse_float, double's range).
std::optional<double> parse_double(std::string_view text);

// Parses an integer (whole text, decimal, optional sign). nullopt when not an integer or
// out of range.
std::optional<long long> parse_integer(std::string_view text);

// --shader STAGE=FILE (render, mesh, gl): FILE relative to the working directory; one
// flag per stage. Throws tessref::Error naming the flag.
std::vector<StageShader> parse_shader_flags(const std::vector<std::string>& flags);
// The scene's [shaders] with each --shader in place of its stage's entry: what the CPU
// pipeline runs through the interpreter (render, mesh; tessref/pipeline.h).
void apply_shader_flags(Scene& scene, const std::vector<StageShader>& flags);
// --max-instructions N (N >= 1): the instruction budget of every invocation of a user's
// shader this process runs (shader.h default_max_instructions); "" leaves the default.
// Throws tessref::Error naming the flag.
void apply_max_instructions_flag(const std::string& text);

// Parses --precision: "gpu" or "exact". Throws tessref::Error naming the flag.
Precision parse_precision_flag(const std::string& text);
// --math exact|llvmpipe (control.h MathMode); anything else is an error naming the flag.
MathMode parse_math_flag(const std::string& text);
// The flags of the commands whose CPU pipeline runs a user's stages (render, mesh), one text
// for both: --math (into `math`), and --shader STAGE=FILE and --max-instructions N.
void add_math_option(CLI::App& app, std::string& math);
void add_cpu_shader_options(CLI::App& app, std::vector<std::string>& shaders, std::string& max_instructions);
// What a summary line adds after "<precision> precision": nothing for exact math (the
// default, so the line reads as it always has), ", llvmpipe math" otherwise.
std::string math_note(MathMode math);

// --threads N for the rest of a command: 0 means every core, N > 0 caps oneTBB's
// parallelism while the object lives, a negative N is a tessref::Error naming the flag.
class ThreadLimit {
public:
    explicit ThreadLimit(int threads);

private:
    std::optional<tbb::global_control> control_;
};

// Parses an image size "WxH" given to `flag` (both 1..16384). Throws tessref::Error.
glm::ivec2 parse_image_size(const std::string& text, const std::string& flag = "--size");

// Parses a comma-separated list of exactly `count` floats given to `flag`, e.g. "1,2,nan,4".
// Throws tessref::Error naming the flag and the item:
//   "item 3: 'x' is not a number" (where: --outer), "expected 4 numbers, got 3" (--outer).
std::vector<float> parse_float_list(std::string_view text, std::size_t count,
                                    const std::string& flag);

// "%.9g" (enough digits for a float to round-trip), with NaN as "nan" whatever its sign
// bit and infinities as "inf" / "-inf".
std::string format_float(float x);
// The shortest "%.<n>g" (n = 1..9) that reads back as the same float: "3.3" rather than
// "3.29999995". For text meant to be retyped (a command line); same NaN/inf spelling.
std::string format_float_short(float x);
// "%.17g" for doubles, same NaN/inf spelling.
std::string format_double(double x);

// `text` (a file name, a scene name) as valid UTF-8 for a JSON report: valid sequences as
// they are, every byte that is not part of one as the four characters "\xNN" (NN its
// value in hex), as Python's "backslashreplace" spells it. JSON strings must be UTF-8, and
// a Linux file name is any bytes: nlohmann::json refuses to dump such a name.
std::string utf8_for_json(std::string_view text);

// ---------------------------------------------------------------------------------------
// Output

// An output file written atomically. The constructor reserves a fresh temporary file next
// to the target (same directory, so the final rename never crosses file systems; same
// extension as the name given, so writers that pick a codec by extension, such as
// OpenImageIO, still work). Write to temp_path(), then commit() puts it in place. If
// commit() is never reached (an exception, an early return, a signal once
// install_signal_cleanup() ran), the temporary file is removed and the target is left
// exactly as it was.
//
// What the target is decides how commit() puts the bytes there:
//  - a regular file or a new name: renamed over it (atomic);
//  - a symlink: followed to the file it names, which is replaced as above; the link stays;
//  - a device, FIFO or socket (/dev/null, /dev/stdout, a pipe): written through, never
//    replaced; the temporary file then lives in the temp directory, and a failed write
//    (/dev/full: "No space left on device") is an Error;
//  - a directory: an Error in the constructor.
// An output that is one of the command's inputs (by inode: common/input_file.h), or the
// same file as another live AtomicOutput, is an Error (in the constructor, or in commit()
// for an input read after it), before anything is replaced.
class AtomicOutput {
public:
    // `temp_extension` (e.g. ".png") overrides the extension of the temporary name, for a
    // writer that must produce a given format whatever the target is called.
    explicit AtomicOutput(std::filesystem::path target, std::string temp_extension = {});
    ~AtomicOutput();
    AtomicOutput(const AtomicOutput&) = delete;
    AtomicOutput& operator=(const AtomicOutput&) = delete;

    const std::filesystem::path& target() const { return target_; }
    const std::filesystem::path& temp_path() const { return temp_; }

    // Writes `bytes` to the temporary file (replacing what it held). Throws tessref::Error.
    void write(std::string_view bytes);
    // Puts the temporary file's bytes at the target (rename, or write-through for a device
    // or FIFO). Throws tessref::Error (and removes the temporary file) when that fails.
    void commit();

private:
    void discard();
    void refuse_an_input() const;
    // The outputs of this process not yet destroyed (one command: one thread makes them).
    static std::vector<const AtomicOutput*>& live_outputs();

    std::filesystem::path target_;    // the name the user gave (for messages)
    std::filesystem::path replaced_;  // the regular file a rename replaces (symlinks followed)
    bool write_through_ = false;      // the target is a device, FIFO or socket
    int write_through_fd_ = -1;       // /dev/stdout, /dev/fd/N: that descriptor, not a reopen
    std::filesystem::path temp_;
    int temp_slot_ = -1;              // the temporary file's entry for the signal handler
    bool committed_ = false;
};

// install_signal_cleanup() (common/temp_cleanup.h) makes SIGINT, SIGTERM, SIGHUP, SIGQUIT
// and SIGPIPE remove every live AtomicOutput temporary file before the signal kills the
// process.

// Writes `bytes` to `target` atomically, or to stdout when target is empty or "-".
void write_output(const std::string& target, std::string_view bytes);

// True when `target` names stdout (empty or "-").
bool is_stdout(const std::string& target);

// ---------------------------------------------------------------------------------------
// Progress

// Progress of a long loop on stderr, shown only when stderr is a terminal: in a pipe, a
// log or a test it prints nothing, so output stays deterministic. Redraws at most a few
// times a second; the line is cleared by finish() or the destructor.
//   Progress progress("rendering", patch_count);
//   for (...) { ...; progress.advance(); }
class Progress {
public:
    Progress(std::string label, std::size_t total);
    ~Progress();
    Progress(const Progress&) = delete;
    Progress& operator=(const Progress&) = delete;

    bool enabled() const { return enabled_; }
    void advance(std::size_t steps = 1);
    void set(std::size_t done);
    void finish();

private:
    void draw(bool force);

    std::string label_;
    std::size_t total_ = 0;
    std::size_t done_ = 0;
    bool enabled_ = false;
    bool drawn_ = false;
    std::chrono::steady_clock::time_point last_draw_{};
};

// True when stderr is a terminal (what Progress checks).
bool stderr_is_terminal();

// Progress of a command's successive stages ("welding", "writing", ...), one line per
// stage, each from 0 to 1; callable as the library's (stage, fraction) progress callbacks.
class StageProgress {
public:
    void operator()(std::string_view stage, double fraction);

private:
    static constexpr std::size_t kSteps = 1000;
    std::string stage_;
    std::unique_ptr<Progress> progress_;
};

}  // namespace tessref::cli
