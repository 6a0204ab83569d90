// The SPIR-V interpreter (tessref/shader.h), instruction class by instruction class: small
// GLSL snippets compiled through the front end and run as vertex shaders, with expected
// values derived by hand (each float written as its bit pattern, with the arithmetic that
// gives it in the comment).
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <set>
#include <string>
#include <vector>

#include <glslang/SPIRV/spirv.hpp>

#include "float_bits.h"
#include "shader/module.h"
#include "tessref/error.h"
#include "tessref/shader.h"

namespace tessref::shader {
namespace {

constexpr const char* kPath = "snippet.vert";

// A vertex shader: `declarations`, then main() { body }. Inputs a, b (vec4 at locations 0,
// 1), outputs r (vec4, location 0) and k (ivec4, location 1).
Module vertex_module(const std::string& body, const std::string& declarations = "") {
    Source s;
    s.stage = ShaderStage::vertex;
    s.path = kPath;
    s.text = "#version 450 core\n"
             "layout(location = 0) in vec4 a;\n"
             "layout(location = 1) in vec4 b;\n"
             "layout(location = 0) out vec4 r;\n"
             "layout(location = 1) out ivec4 k;\n" +
             declarations + "\nvoid main()\n{\n" + body + "\n}\n";
    return Module::compile(s);
}

struct Outcome {
    glm::vec4 r{0.0f};
    std::array<std::uint32_t, 4> k{};
    std::vector<std::string> warnings;
};

Outcome run_vertex(const std::string& body, glm::vec4 a = glm::vec4(0.0f), glm::vec4 b = glm::vec4(0.0f),
               const Bindings& bindings = {}, const std::string& declarations = "") {
    Outcome out;
    RunOptions options;
    options.warnings = &out.warnings;
    Executable e(vertex_module(body, declarations), bindings, options);
    const Slot attributes[] = {slot(a), slot(b)};
    const ShaderVertex v = e.vertex(attributes, 0);
    if (v.locations.size() > 0) out.r = as_vec4(v.locations[0]);
    if (v.locations.size() > 1) out.k = v.locations[1];
    return out;
}


// ---- float arithmetic: each operation rounded on its own -----------------------------

TEST(ShaderFloat, EachOperationRoundsToFloat) {
    // 1 + 2^-24 lies halfway between 1 and 1 + 2^-23: ties to even gives 1 (in double it
    // would stay 1.0000000596).
    EXPECT_EQ(run_vertex("r.x = a.x + a.y;", {1.0f, 0x1p-24f, 0, 0}).r.x, 1.0f);
    // 1 / 3 = 0.0101...b: rounded to nearest, 0x3eaaaaab (the last bit rounds up).
    EXPECT_EQ(bits(run_vertex("r.x = a.x / a.y;", {1.0f, 3.0f, 0, 0}).r.x), 0x3eaaaaabu);
}

TEST(ShaderFloat, NoContraction) {
    // a = 1 + 2^-12: a * a = 1 + 2^-11 + 2^-24 exactly, which rounds (tie, to even) to
    // 1 + 2^-11; minus c = 1 + 2^-11 gives 0. A fused multiply-add would give 2^-24.
    const float x = 1.0f + 0x1p-12f;
    EXPECT_EQ(run_vertex("r.x = a.x * a.y - a.z;", {x, x, 1.0f + 0x1p-11f, 0}).r.x, 0.0f);
    // fma() itself is fused: 2^-24.
    EXPECT_EQ(run_vertex("r.x = fma(a.x, a.y, -a.z);", {x, x, 1.0f + 0x1p-11f, 0}).r.x, 0x1p-24f);
}

TEST(ShaderFloat, NanAndInfinityPropagate) {
    const Outcome run = run_vertex("r = vec4(a.x / a.y, a.z / a.y, a.w - a.w, a.y * a.w);",
                               {1.0f, 0.0f, -1.0f, std::numeric_limits<float>::infinity()});
    EXPECT_EQ(run.r.x, std::numeric_limits<float>::infinity());   // 1 / 0
    EXPECT_EQ(run.r.y, -std::numeric_limits<float>::infinity());  // -1 / 0
    EXPECT_TRUE(std::isnan(run.r.z));                             // inf - inf
    EXPECT_TRUE(std::isnan(run.r.w));                             // 0 * inf
    // Ordered comparisons with a NaN are false; isnan sees it.
    const Outcome c = run_vertex("float n = a.x / a.y; k = ivec4(n < 1.0, n > 1.0, n == n, isnan(n));", {0.0f, 0.0f, 0, 0});
    EXPECT_EQ(c.k, (std::array<std::uint32_t, 4>{0, 0, 0, 1}));
}

TEST(ShaderFloat, NegationFlipsTheSignOfZero) {
    EXPECT_EQ(bits(run_vertex("r.x = -a.x;", {0.0f, 0, 0, 0}).r.x), 0x80000000u);
}

TEST(ShaderFloat, ModIsXMinusYTimesFloorOfTheQuotient) {
    // mod(-1, 3) = -1 - 3 * floor(-1/3) = -1 + 3 = 2; mod(5.5, 2) = 1.5.
    const Outcome run = run_vertex("r.x = mod(a.x, a.y); r.y = mod(a.z, a.w);", {-1.0f, 3.0f, 5.5f, 2.0f});
    EXPECT_EQ(run.r.x, 2.0f);
    EXPECT_EQ(run.r.y, 1.5f);
}

// ---- integers: wrapping, division by zero as documented --------------------------------

TEST(ShaderInt, AdditionAndMultiplicationWrap) {
    Bindings b;
    b.set("i", 2147483647);
    b.set("j", 65536);
    const Outcome run = run_vertex("k = ivec4(i + 1, j * j, -(i + 1), i * 2);", {}, {}, b, "uniform int i;\nuniform int j;");
    EXPECT_EQ(run.k[0], 0x80000000u);  // INT_MAX + 1 = INT_MIN
    EXPECT_EQ(run.k[1], 0u);           // 2^16 * 2^16 = 2^32 = 0 mod 2^32
    EXPECT_EQ(run.k[2], 0x80000000u);  // -INT_MIN = INT_MIN
    EXPECT_EQ(run.k[3], 0xfffffffeu);  // INT_MAX * 2 = -2
}

// GLSL's % compiles to OpSMod, whose result takes the divisor's sign: -7 % 2 = 1 (OpSRem
// would give -1).
TEST(ShaderInt, DivisionTruncatesAndRemainderTakesTheDivisorsSign) {
    Bindings b;
    b.set("i", -7);
    b.set("j", 2);
    const Outcome run = run_vertex("k = ivec4(i / j, i % j, (-i) / j, (-i) % j);", {}, {}, b, "uniform int i;\nuniform int j;");
    EXPECT_EQ(run.k, (std::array<std::uint32_t, 4>{static_cast<std::uint32_t>(-3), 1, 3, 1}));
    EXPECT_TRUE(run.warnings.empty());
}

TEST(ShaderInt, DivisionByZeroIsDocumentedAndWarned) {
    Bindings b;
    b.set("i", 7);
    b.set("zero", 0);
    b.set("minimum", std::numeric_limits<int>::min());
    b.set("minus_one", -1);
    const Outcome run = run_vertex("k = ivec4(i / zero, i % zero, minimum / minus_one, int(uint(i) / uint(zero)));", {}, {}, b,
                               "uniform int i;\nuniform int zero;\nuniform int minimum;\nuniform int minus_one;");
    EXPECT_EQ(run.k[0], 0xffffffffu);  // x / 0: all ones (-1)
    EXPECT_EQ(run.k[1], 7u);           // x % 0: x
    EXPECT_EQ(run.k[2], 0x80000000u);  // INT_MIN / -1 = INT_MIN
    EXPECT_EQ(run.k[3], 0xffffffffu);  // unsigned x / 0: 0xffffffff
    ASSERT_FALSE(run.warnings.empty());
    EXPECT_NE(run.warnings[0].find("by zero"), std::string::npos) << run.warnings[0];
    EXPECT_NE(run.warnings[0].find("snippet.vert:"), std::string::npos) << run.warnings[0];
}

TEST(ShaderInt, ShiftsAndBits) {
    Bindings b;
    b.set("i", -16);
    b.set("n", 2);
    const Outcome run = run_vertex("k = ivec4(i >> n, int(uint(i) >> uint(n)), i << n, ~i);", {}, {}, b,
                               "uniform int i;\nuniform int n;");
    EXPECT_EQ(run.k[0], static_cast<std::uint32_t>(-4));  // arithmetic
    EXPECT_EQ(run.k[1], 0x3ffffffcu);                     // logical: 0xfffffff0 >> 2
    EXPECT_EQ(run.k[2], static_cast<std::uint32_t>(-64));
    EXPECT_EQ(run.k[3], 15u);
}

// ---- conversions -----------------------------------------------------------------------

TEST(ShaderConvert, FloatToIntTruncatesAndSaturates) {
    const Outcome run = run_vertex("k = ivec4(int(a.x), int(a.y), int(a.z), int(a.w));", {-1.5f, 2.99f, 3e9f, 0.0f});
    EXPECT_EQ(run.k[0], static_cast<std::uint32_t>(-1));
    EXPECT_EQ(run.k[1], 2u);
    EXPECT_EQ(run.k[2], 0x7fffffffu);  // out of range: saturated, with a warning
    EXPECT_EQ(run.k[3], 0u);
    ASSERT_EQ(run.warnings.size(), 1u);
    const Outcome nan = run_vertex("k.x = int(a.x / a.y);", {0.0f, 0.0f, 0, 0});
    EXPECT_EQ(nan.k[0], 0u);  // NaN -> 0
}

TEST(ShaderConvert, IntToFloatRoundsToNearestEven) {
    Bindings b;
    b.set("i", 16777217);  // 2^24 + 1: halfway between 2^24 and 2^24 + 2, ties to even
    b.set("j", 16777219);  // 2^24 + 3: halfway between 2^24 + 2 and 2^24 + 4, to even (2^24 + 4)
    const Outcome run = run_vertex("r.x = float(i); r.y = float(j);", {}, {}, b, "uniform int i;\nuniform int j;");
    EXPECT_EQ(run.r.x, 16777216.0f);
    EXPECT_EQ(run.r.y, 16777220.0f);
}

// ---- composites ------------------------------------------------------------------------

TEST(ShaderComposite, SwizzlesConstructorsAndInserts) {
    const Outcome run = run_vertex("vec4 v = vec4(a.wzy, 9.0); v.y = b.x; r = v.zyxw;", {1, 2, 3, 4}, {7, 0, 0, 0});
    EXPECT_EQ(run.r, glm::vec4(2.0f, 7.0f, 4.0f, 9.0f));
}

TEST(ShaderComposite, MatrixTimesVectorSumsTheColumnsInOrder) {
    // mat2(columns (1, 2), (3, 4)) * (5, 6) = (1*5 + 3*6, 2*5 + 4*6) = (23, 34);
    // (5, 6) * M = (dot(v, column 0), dot(v, column 1)) = (17, 39).
    const Outcome run = run_vertex("mat2 m = mat2(a.x, a.y, a.z, a.w); r.xy = m * b.xy; r.zw = b.xy * m;", {1, 2, 3, 4},
                               {5, 6, 0, 0});
    EXPECT_EQ(run.r, glm::vec4(23.0f, 34.0f, 17.0f, 39.0f));
    // The order is visible in rounding: (2^24 + 1 - 2^24) depends on it. Columns
    // (2^24, 0), (1, 0), (-2^24, 0) times (1, 1, 1): ((2^24 + 1) - 2^24) = 2^24 - 2^24 = 0
    // summing from the first column (2^24 + 1 rounds to 2^24); 1 from the last.
    const Outcome order = run_vertex("mat3 m = mat3(vec3(a.x, 0, 0), vec3(a.y, 0, 0), vec3(a.z, 0, 0)); r.xyz = m * vec3(1.0);",
                                 {16777216.0f, 1.0f, -16777216.0f, 0});
    EXPECT_EQ(order.r.x, 0.0f);
    // Four columns pairwise, as GLM: columns 2^24, 1, 1, -2^24 (x only) times (1, 1, 1, 1):
    // (2^24 + 1) + (1 - 2^24) = 2^24 + (-16777215) = 1; from the first column on it would
    // be ((2^24 + 1) + 1) - 2^24 = 0.
    const Outcome four = run_vertex("mat4 m = mat4(vec4(a.x, 0, 0, 0), vec4(a.y, 0, 0, 0), vec4(a.z, 0, 0, 0), "
                                    "vec4(a.w, 0, 0, 0)); r = m * vec4(1.0);",
                                    {16777216.0f, 1.0f, 1.0f, -16777216.0f});
    EXPECT_EQ(four.r.x, 1.0f);
}

TEST(ShaderComposite, ArraysStructsAndDynamicIndices) {
    const std::string declarations = "struct S { float x; vec2 y[3]; };";
    const Outcome run = run_vertex(
        "S s; s.x = a.x; for (int i = 0; i < 3; ++i) s.y[i] = vec2(float(i), a.y * float(i));\n"
        "int j = int(b.x); r = vec4(s.x, s.y[j].y, s.y[j - 1].x, s.y[2].y);",
        {1.5f, 10.0f, 0, 0}, {2.0f, 0, 0, 0}, {}, declarations);
    EXPECT_EQ(run.r, glm::vec4(1.5f, 20.0f, 1.0f, 20.0f));
    EXPECT_TRUE(run.warnings.empty());
}

TEST(ShaderComposite, AnIndexOutOfRangeIsClampedWithAWarning) {
    const Outcome run = run_vertex("float v[3] = float[3](a.x, a.y, a.z); int j = int(b.x); r.x = v[j];", {1, 2, 3, 0},
                               {5.0f, 0, 0, 0});
    EXPECT_EQ(run.r.x, 3.0f);  // index 5 clamped to 2
    ASSERT_EQ(run.warnings.size(), 1u);
    EXPECT_NE(run.warnings[0].find("index 5 out of range"), std::string::npos) << run.warnings[0];
    EXPECT_NE(run.warnings[0].find("snippet.vert:"), std::string::npos) << run.warnings[0];
}

// ---- control flow --------------------------------------------------------------------

TEST(ShaderControl, LoopsBreakContinueAndSwitch) {
    const Outcome run = run_vertex(
        "int n = int(a.x); int sum = 0;\n"
        "for (int i = 1; i <= n; ++i) { if (i == 3) continue; if (i > 8) break; sum += i; }\n"
        "int w = 0; int t = 0; while (w < 5) { w++; t += w; }\n"
        "int s = 0; switch (int(a.y)) { case 1: s = 10; break; case 2: s = 20; default: s += 1; }\n"
        "k = ivec4(sum, t, s, 0);",
        {10.0f, 2.0f, 0, 0});
    // 1+2+4+5+6+7+8 = 33; 1+2+3+4+5 = 15; case 2 falls through to default: 21.
    EXPECT_EQ(run.k, (std::array<std::uint32_t, 4>{33, 15, 21, 0}));
}

TEST(ShaderControl, FunctionsWithOutParametersAndEarlyReturn) {
    const std::string declarations =
        "float first_positive(vec4 v, out int at) {\n"
        "  for (int i = 0; i < 4; ++i) { if (v[i] > 0.0) { at = i; return v[i]; } }\n"
        "  at = -1; return 0.0; }\n";
    const Outcome run = run_vertex("int at; r.x = first_positive(a, at); k.x = at; int at2; r.y = first_positive(b, at2); k.y = at2;",
                               {-1.0f, 0.0f, 7.0f, 8.0f}, {-1.0f, -2.0f, -3.0f, -4.0f}, {}, declarations);
    EXPECT_EQ(run.r.x, 7.0f);
    EXPECT_EQ(run.k[0], 2u);
    EXPECT_EQ(run.r.y, 0.0f);
    EXPECT_EQ(run.k[1], 0xffffffffu);
}

TEST(ShaderControl, ShortCircuitLogicRunsThroughPhi) {
    // glslang compiles && and || to branches joined by OpPhi; the right operand is not run
    // when the left decides (it would divide by zero and warn).
    Bindings b;
    b.set("zero", 0);
    const Outcome run = run_vertex("bool t = a.x > 0.0 && (100 / zero) > 0; bool u = a.x < 0.0 || a.y > 0.0; k = ivec4(t, u, 0, 0);",
                               {-1.0f, 1.0f, 0, 0}, {}, b, "uniform int zero;");
    EXPECT_EQ(run.k[0], 0u);
    EXPECT_EQ(run.k[1], 1u);
    EXPECT_TRUE(run.warnings.empty());
}

// ---- GLSL.std.450, exact mode ----------------------------------------------------------

TEST(ShaderStd450, ExactModeIsCorrectlyRounded) {
    // Known float constants: pi = 0x40490fdb, e = 0x402df854, sqrt(2) = 0x3fb504f3,
    // pi/2 = 0x3fc90fdb.
    const Outcome run = run_vertex("r = vec4(acos(a.x), exp(a.y), sqrt(a.z), asin(a.y));", {-1.0f, 1.0f, 2.0f, 0});
    EXPECT_EQ(bits(run.r.x), 0x40490fdbu);
    EXPECT_EQ(bits(run.r.y), 0x402df854u);
    EXPECT_EQ(bits(run.r.z), 0x3fb504f3u);
    EXPECT_EQ(bits(run.r.w), 0x3fc90fdbu);
}

TEST(ShaderStd450, MixIsXPlusATimesYMinusX) {
    // mix(3, 3, 0.1f) = 3 + 0.1f * 0 = 3 exactly; x * (1 - a) + y * a would round through
    // 0.9f and 0.3f to 0x403fffff. mix(7, 2, 0.1f) = 7 - 0.50000000745 = 6.49999999255,
    // whose nearest float is 6.5 (the other form gives 0x40cfffff).
    const Outcome run = run_vertex("r.x = mix(a.x, a.y, a.z); r.y = mix(a.w, b.x, a.z);", {3.0f, 3.0f, 0.1f, 7.0f},
                                   {2.0f, 0, 0, 0});
    EXPECT_EQ(run.r.x, 3.0f);
    EXPECT_EQ(run.r.y, 6.5f);
}

TEST(ShaderStd450, ClampMinMaxAndGeometry) {
    const Outcome run = run_vertex("r = vec4(clamp(a.x, -1.0, 1.0), length(a.yz), distance(a.yz, vec2(0.0)), "
                               "normalize(vec2(a.w, 0.0)).x);",
                               {1.5f, 3.0f, 4.0f, -2.0f});
    EXPECT_EQ(run.r, glm::vec4(1.0f, 5.0f, 5.0f, -1.0f));  // 3-4-5; normalize(-2, 0) = (-1, 0)
}

// ---- errors ------------------------------------------------------------------------------

TEST(ShaderErrors, CompileErrorNamesTheFileAndLine) {
    try {
        vertex_module("r = undefined_name;");
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_EQ(e.where().file, kPath);
        EXPECT_EQ(e.where().line, 9) << e.message();  // the body's line
        EXPECT_NE(std::string(e.what()).find("undefined_name"), std::string::npos) << e.what();
    }
}

TEST(ShaderErrors, UnsupportedOpcodeNamesItAndTheLine) {
    try {
        Bindings b;
        run_vertex("k.x = bitfieldReverse(int(a.x));", {}, {}, b);
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("OpBitReverse"), std::string::npos) << e.what();
        EXPECT_EQ(e.where().file, kPath);
        EXPECT_EQ(e.where().line, 9) << e.message();
    }
}

TEST(ShaderErrors, UnsupportedExecutionModelAndTypes) {
    // A compute shader (GLSL's front end here takes the five graphics stages only: an empty
    // vertex shader's entry point made GLCompute, with its LocalSize).
    Source s;
    s.stage = ShaderStage::vertex;
    s.path = "x.vert";
    s.text = "#version 450 core\nvoid main() { }\n";
    std::vector<std::uint32_t> spirv = Module::compile(s).spirv();
    bool patched = false;
    for (std::size_t k = 5; k < spirv.size(); k += spirv[k] >> 16) {
        if ((spirv[k] & 0xffffu) != 15u) continue;  // OpEntryPoint
        spirv[k + 1] = 5u;                          // ExecutionModelGLCompute
        // OpExecutionMode %main LocalSize 1 1 1, right after the entry point.
        const std::size_t next = k + (spirv[k] >> 16);
        spirv.insert(spirv.begin() + static_cast<std::ptrdiff_t>(next), {(6u << 16) | 16u, spirv[k + 2], 17u, 1u, 1u, 1u});
        patched = true;
        break;
    }
    ASSERT_TRUE(patched);
    try {
        Module::load(spirv, "x.comp");
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("GLCompute"), std::string::npos) << e.what();
    }
    try {
        vertex_module("r.x = float(d);", "uniform double d;");
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("capability Float64 is not supported by the interpreter"), std::string::npos)
            << e.what();
    }
}

// The names in those messages are SPIR-V's spelling (the specification's enumerants); an
// opcode no name exists for is given as its number.
TEST(ShaderErrors, OpcodeCapabilityAndExecutionModelNames) {
    EXPECT_EQ(tessref::shader::opcode_name(spv::OpBitReverse), "OpBitReverse");
    EXPECT_EQ(tessref::shader::opcode_name(spv::OpFMul), "OpFMul");
    EXPECT_EQ(tessref::shader::opcode_name(spv::OpEmitVertex), "OpEmitVertex");
    EXPECT_EQ(tessref::shader::opcode_name(0xfff0u), "opcode 65520");

    // A valid module that declares a capability the interpreter does not run (an OpCapability
    // added after the first); the execution model's name is checked with GLCompute above.
    Source s;
    s.stage = ShaderStage::vertex;
    s.path = "x.vert";
    s.text = "#version 450 core\nvoid main() { }\n";
    std::vector<std::uint32_t> spirv = Module::compile(s).spirv();
    ASSERT_EQ(spirv[5] & 0xffffu, static_cast<std::uint32_t>(spv::OpCapability));
    spirv.insert(spirv.begin() + 7, {(2u << 16) | spv::OpCapability, spv::CapabilityInt64});
    try {
        Module::load(spirv, "x.vert");
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("capability Int64 is not supported"), std::string::npos) << e.what();
    }
}

TEST(ShaderErrors, AnEndlessLoopRunsIntoTheInstructionBudget) {
    Bindings b;
    b.set("n", 1);
    RunOptions options;
    options.max_instructions = 10000;
    Executable e(vertex_module("int i = 0; while (i < 10 * n) { i = i * n; } r.x = float(i);", "uniform int n;"), b, options);
    try {
        e.vertex({}, 3);
        FAIL() << "no error";
    } catch (const Error& err) {
        EXPECT_NE(std::string(err.what()).find("instruction budget of 10000"), std::string::npos) << err.what();
        EXPECT_NE(std::string(err.what()).find("vertex shader"), std::string::npos) << err.what();
        EXPECT_NE(std::string(err.what()).find("invocation 3"), std::string::npos) << err.what();
    }
}

TEST(ShaderErrors, AUniformOfAnotherType) {
    Bindings b;
    b.set("s", glm::vec3(1.0f));
    EXPECT_THROW(Executable(vertex_module("r.x = s;", "uniform float s;"), b, {}), Error);
}

// ---- uniforms ------------------------------------------------------------------------------

TEST(ShaderUniforms, SetByNameInitializersAndDefaults) {
    Bindings b;
    b.set("scale", 2.0f);
    b.set("m", glm::mat4(1.0f) * 3.0f);
    const Outcome run = run_vertex("r = vec4(scale, withDefault, unset, (m * vec4(1.0)).y);", {}, {}, b,
                               "uniform float scale;\nuniform float withDefault = 0.75;\nuniform float unset;\nuniform mat4 m;");
    EXPECT_EQ(run.r, glm::vec4(2.0f, 0.75f, 0.0f, 3.0f));
}

// ---- tessellation control: barriers ------------------------------------------------------

TEST(ShaderControlStage, EveryInvocationReachesTheBarrierBeforeAnyPassesIt) {
    Source s;
    s.stage = ShaderStage::tess_control;
    s.path = "barrier.tesc";
    s.text = R"(#version 450 core
layout(vertices = 3) out;
layout(location = 0) out float value[];
layout(location = 1) patch out float total;
void main()
{
    value[gl_InvocationID] = float(gl_InvocationID + 1) * gl_in[gl_InvocationID].gl_Position.x;
    barrier();
    if (gl_InvocationID == 0) {
        total = value[0] + value[1] + value[2];
        gl_TessLevelOuter[0] = total;
        gl_TessLevelInner[0] = float(gl_PrimitiveID);
    }
}
)";
    Executable e(Module::compile(s), {}, {});
    std::vector<ShaderVertex> in(3);
    in[0].position = glm::vec4(1.0f);
    in[1].position = glm::vec4(10.0f);
    in[2].position = glm::vec4(100.0f);
    const ShaderPatch patch = e.control(in, 7);
    // 1 * 1 + 2 * 10 + 3 * 100; invocation 0 alone would see 1 + 0 + 0.
    EXPECT_EQ(patch.outer[0], 321.0f);
    EXPECT_EQ(patch.inner[0], 7.0f);
    ASSERT_EQ(patch.vertices.size(), 3u);
    EXPECT_EQ(as_vec4(patch.vertices[2].locations[0]).x, 300.0f);
    ASSERT_GT(patch.patch_locations.size(), 1u);
    EXPECT_EQ(as_vec4(patch.patch_locations[1]).x, 321.0f);
}


// The order of a sum of products is the math mode's (shader.h). v = (1, 1e8, -1e8, 1): 1e8
// + 1 rounds back to 1e8 in float (its spacing there is 8), so the order decides.
//   dot(v.xyz, 1): exact ((1 + 1e8) + -1e8) = 0; llvmpipe, from the last component,
//   ((-1e8 + 1e8) + 1) = 1.
//   (m * 1).x with m's first row v: exact pairwise (1 + 1e8) + (-1e8 + 1) = 1e8 - 1e8 = 0;
//   llvmpipe from the first column ((1 + 1e8) + -1e8) + 1 = 1.
TEST(ShaderStd450, SumsOfProductsFollowTheMathMode) {
    const std::string body = "vec4 v = vec4(1.0, 1.0e8, -1.0e8, 1.0);\n"
                             "mat4 m = transpose(mat4(v, v, v, v));\n"
                             "r = vec4(dot(v.xyz, vec3(1.0)), (m * vec4(1.0)).x, 0.0, 0.0);";
    for (const MathMode math : {MathMode::exact, MathMode::llvmpipe}) {
        RunOptions options;
        options.math = math;
        Executable e(vertex_module(body), {}, options);
        const ShaderVertex v = e.vertex({}, 0);
        ASSERT_FALSE(v.locations.empty());
        const glm::vec4 r = as_vec4(v.locations[0]);
        const float expected = math == MathMode::exact ? 0.0f : 1.0f;
        EXPECT_EQ(r.x, expected) << to_string(math);
        EXPECT_EQ(r.y, expected) << to_string(math);
    }
}

// ---- batched evaluation: one instruction over many invocations ----------------------------

namespace batch {

// An evaluation shader whose invocations part ways: branches and a loop whose trip count
// depends on gl_TessCoord, a local array and the patch's vertices indexed per invocation
// (one index out of range for some), a texture read, GLSL.std.450 calls, a matrix product
// and a function with an early return.
constexpr const char* kDivergent = R"(#version 450 core
layout(quads, equal_spacing, ccw) in;
layout(location = 0) in vec4 corner[];
layout(location = 0) out vec4 r;
layout(location = 1) out ivec4 k;
layout(binding = 0) uniform sampler2D map;
uniform mat4 m;

float shaped(float x)
{
    if (x > 0.75)
        return sqrt(x);
    return x * x;
}

void main()
{
    float u = gl_TessCoord.x, v = gl_TessCoord.y;
    int steps = int(u * 7.0);
    float sum = 0.0;
    float table[5] = float[5](0.5, 1.5, 2.5, 3.5, 4.5);
    for (int i = 0; i < steps; ++i) {
        if (i % 3 == 2)
            continue;
        sum += table[i];
    }
    vec4 c = corner[int(v * 3.99)];
    vec4 p = u < 0.5 ? mix(c, corner[3], v) : m * c;
    switch (steps) {
        case 0: p.w = -1.0; break;
        case 4: p.w = acos(v); break;
        default: p.w = shaped(v); break;
    }
    r = p + vec4(sum) + texture(map, vec2(u, v));
    k = ivec4(steps, int(v * 100.0), gl_PrimitiveID, 0);
}
)";

Module divergent_module() {
    Source s;
    s.stage = ShaderStage::tess_evaluation;
    s.path = "divergent.tese";
    s.text = kDivergent;
    return Module::compile(s);
}

ShaderPatch four_corners() {
    ShaderPatch patch;
    patch.vertices.resize(4);
    for (int j = 0; j < 4; ++j)
        patch.vertices[static_cast<std::size_t>(j)].locations = {slot(glm::vec4(1.0f + static_cast<float>(j), 0.5f, -2.0f, 1.0f))};
    return patch;
}

// The coordinates of a 23 x 13 grid (299 points: several lane chunks and a partial one).
std::vector<glm::vec3> grid_coords() {
    std::vector<glm::vec3> out;
    for (int i = 0; i < 23; ++i)
        for (int j = 0; j < 13; ++j)
            out.emplace_back(static_cast<float>(i) / 22.0f, static_cast<float>(j) / 12.0f, 0.0f);
    return out;
}

}  // namespace batch

TEST(ShaderBatch, ABatchOfInvocationsGivesEachInvocationsOwnValues) {
    // A 2 x 2 texture, so that texture() reads a bilinear mix that varies over the domain.
    const Texture texture = Texture::from_unorm8(2, 2, 4, std::vector<std::uint8_t>{0, 64, 128, 255, 255, 128, 64, 0,
                                                                          32, 32, 32, 32, 200, 100, 50, 25});
    Bindings b;
    b.set("m", glm::mat4(glm::vec4(1.0f, 2.0f, 3.0f, 0.0f), glm::vec4(0.5f, 0.25f, 0.125f, 0.0f),
                         glm::vec4(-1.0f, 1.0f, -1.0f, 0.0f), glm::vec4(0.1f, 0.2f, 0.3f, 1.0f)));
    b.bind_texture(0, &texture);
    for (const MathMode math : {MathMode::exact, MathMode::llvmpipe}) {
        std::vector<std::string> single_warnings, batch_warnings;
        RunOptions single_options, batch_options;
        single_options.math = batch_options.math = math;
        single_options.warnings = &single_warnings;
        batch_options.warnings = &batch_warnings;
        const Executable single(batch::divergent_module(), b, single_options);
        const Executable batched(batch::divergent_module(), b, batch_options);
        const ShaderPatch patch = batch::four_corners();
        const std::vector<glm::vec3> coords = batch::grid_coords();
        const std::vector<ShaderVertex> out = batched.evaluate(patch, coords, 11);
        ASSERT_EQ(out.size(), coords.size());
        std::set<std::uint32_t> steps;
        for (std::size_t j = 0; j < coords.size(); ++j) {
            const ShaderVertex one = single.evaluate(patch, coords[j], 11);
            ASSERT_EQ(out[j].locations.size(), one.locations.size()) << j;
            for (std::size_t l = 0; l < one.locations.size(); ++l)
                EXPECT_EQ(out[j].locations[l], one.locations[l]) << "point " << j << ", location " << l;
            EXPECT_EQ(std::bit_cast<glm::uvec4>(out[j].position), std::bit_cast<glm::uvec4>(one.position)) << j;
            steps.insert(one.locations[1][0]);
        }
        EXPECT_EQ(steps.size(), 8u);  // every trip count 0..7 was met: the invocations diverged
        // Once per line and call: the single calls warned once for each point that met it.
        EXPECT_FALSE(batch_warnings.empty());
        EXPECT_EQ(std::set<std::string>(batch_warnings.begin(), batch_warnings.end()),
                  std::set<std::string>(single_warnings.begin(), single_warnings.end()));
    }
}

TEST(ShaderBatch, ABatchRunsIntoTheBudgetAsOneInvocationWould) {
    Source s;
    s.stage = ShaderStage::tess_evaluation;
    s.path = "endless.tese";
    s.text = "#version 450 core\nlayout(triangles) in;\nlayout(location = 0) out float r;\n"
             "void main() { float x = gl_TessCoord.x; while (x >= 0.0) { x = x * 0.5; } r = x; }\n";
    RunOptions options;
    options.max_instructions = 5000;
    const Executable e(Module::compile(s), {}, options);
    const std::vector<glm::vec3> coords = {{0.25f, 0.25f, 0.5f}, {0.0f, 0.5f, 0.5f}};
    try {
        e.evaluate(ShaderPatch{}, coords, 4);
        FAIL() << "no error";
    } catch (const Error& err) {
        EXPECT_NE(std::string(err.what()).find("instruction budget of 5000"), std::string::npos) << err.what();
        EXPECT_NE(std::string(err.what()).find("patch 4"), std::string::npos) << err.what();
    }
}

}  // namespace
}  // namespace tessref::shader
