// The geometry execution model of the SPIR-V interpreter (tessref/shader.h,
// Executable::geometry): gl_in[] and input blocks, EmitVertex() and EndPrimitive(), output
// strips assembled into triangles, lines and points as GL assembles them, max_vertices,
// layout(invocations = N). Small GLSL geometry shaders with expected values derived by hand.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "tessref/error.h"
#include "tessref/shader.h"

namespace tessref::shader {
namespace {

constexpr const char* kPath = "snippet.geom";

// A geometry shader: the layout lines, then an input block `v` (vec4 value at location 0)
// of `inputs` vertices, an output `o` (vec4, location 0), `declarations`, main() { body }.
Module geometry_module(const std::string& layout, const std::string& body, int inputs = 3,
                       const std::string& declarations = "") {
    Source s;
    s.stage = ShaderStage::geometry;
    s.path = kPath;
    s.text = "#version 450 core\n" + layout +
             "\n"
             "layout(location = 0) in Data { vec4 value; } v[" +
             std::to_string(inputs) +
             "];\n"
             "layout(location = 0) out vec4 o;\n" +
             declarations + "\nvoid main()\n{\n" + body + "\n}\n";
    return Module::compile(s);
}

// Input vertex k: gl_Position (k, 10 k, 0, 1), value (100 + k, 0, 0, 0).
std::vector<ShaderVertex> inputs(int n) {
    std::vector<ShaderVertex> in(static_cast<std::size_t>(n));
    for (int k = 0; k < n; ++k) {
        in[static_cast<std::size_t>(k)].position = glm::vec4(static_cast<float>(k), 10.0f * static_cast<float>(k), 0.0f, 1.0f);
        in[static_cast<std::size_t>(k)].locations = {slot(glm::vec4(100.0f + static_cast<float>(k), 0.0f, 0.0f, 0.0f))};
    }
    return in;
}

ShaderPrimitives run(const Module& module, int vertices, long long primitive = 0, std::vector<std::string>* warnings = nullptr) {
    RunOptions options;
    options.warnings = warnings;
    const Executable e(module, {}, options);
    const std::vector<ShaderVertex> in = inputs(vertices);
    return e.geometry(in, primitive);
}

float o_x(const ShaderPrimitives& p, std::size_t k) { return as_vec4(p.vertices.at(k).locations.at(0)).x; }

TEST(ShaderGeometry, EmitVertexHandsOnTheOutputsAsTheyAreThen) {
    // Each vertex: gl_Position from gl_in[i], o.x = v[i].value.x + 0.5 (100.5, 101.5, 102.5).
    const Module m = geometry_module("layout(triangles) in;\nlayout(triangle_strip, max_vertices = 3) out;",
                                     "for (int i = 0; i < 3; i++) {\n"
                                     "    gl_Position = gl_in[i].gl_Position;\n"
                                     "    o = v[i].value + vec4(0.5);\n"
                                     "    EmitVertex();\n"
                                     "}\n"
                                     "EndPrimitive();");
    const ShaderPrimitives p = run(m, 3);
    ASSERT_EQ(p.vertices.size(), 3u);
    for (std::size_t k = 0; k < 3; ++k) {
        EXPECT_EQ(p.vertices[k].position, glm::vec4(static_cast<float>(k), 10.0f * static_cast<float>(k), 0.0f, 1.0f));
        EXPECT_EQ(o_x(p, k), 100.5f + static_cast<float>(k));
    }
    EXPECT_EQ(p.output, GeometryOutput::triangle_strip);
    EXPECT_EQ(p.indices, (std::vector<std::uint32_t>{0, 1, 2}));
    EXPECT_EQ(p.primitive_count(), 1u);
}

TEST(ShaderGeometry, ATriangleStripAlternatesItsFirstTwoVertices) {
    // Five vertices in one strip: triangles k = 0, 1, 2 are (0 1 2), (2 1 3), (2 3 4): the odd
    // one swaps its first two so that all three wind as the first; the last vertex of each
    // is the newest (GL's provoking vertex).
    const Module m = geometry_module("layout(triangles) in;\nlayout(triangle_strip, max_vertices = 5) out;",
                                     "for (int i = 0; i < 5; i++) {\n"
                                     "    o = vec4(float(i));\n"
                                     "    EmitVertex();\n"
                                     "}");  // no EndPrimitive(): the end of the invocation ends the strip
    const ShaderPrimitives p = run(m, 3);
    ASSERT_EQ(p.vertices.size(), 5u);
    for (std::size_t k = 0; k < 5; ++k) EXPECT_EQ(o_x(p, k), static_cast<float>(k));
    EXPECT_EQ(p.indices, (std::vector<std::uint32_t>{0, 1, 2, 2, 1, 3, 2, 3, 4}));
}

TEST(ShaderGeometry, EndPrimitiveCutsTheStripAndAShortStripMakesNothing) {
    // Strip one: vertices 0..3, triangles (0 1 2), (2 1 3). Strip two: vertex 4 alone, too
    // short for a triangle: emitted, in no primitive. Strip three: 5..8, its triangles
    // alternating from its own start: (5 6 7), (7 6 8) (counted from the first vertex of all
    // they would be (6 5 7), (6 7 8)).
    const Module m = geometry_module("layout(triangles) in;\nlayout(triangle_strip, max_vertices = 9) out;",
                                     "int n = 0;\n"
                                     "for (int i = 0; i < 4; i++) { o = vec4(float(n++)); EmitVertex(); }\n"
                                     "EndPrimitive();\n"
                                     "o = vec4(float(n++)); EmitVertex();\n"
                                     "EndPrimitive();\n"
                                     "EndPrimitive();\n"  // an empty strip
                                     "for (int i = 0; i < 4; i++) { o = vec4(float(n++)); EmitVertex(); }\n");
    const ShaderPrimitives p = run(m, 3);
    ASSERT_EQ(p.vertices.size(), 9u);
    EXPECT_EQ(o_x(p, 8), 8.0f);
    EXPECT_EQ(p.indices, (std::vector<std::uint32_t>{0, 1, 2, 2, 1, 3, 5, 6, 7, 7, 6, 8}));
}

TEST(ShaderGeometry, VerticesPastMaxVerticesAreDroppedWithAWarning) {
    // max_vertices = 4, five emitted: the fifth (o = 4) is dropped; the strip of four makes
    // two triangles.
    const Module m = geometry_module("layout(triangles) in;\nlayout(triangle_strip, max_vertices = 4) out;",
                                     "for (int i = 0; i < 5; i++) { o = vec4(float(i)); EmitVertex(); }");
    std::vector<std::string> warnings;
    const ShaderPrimitives p = run(m, 3, 7, &warnings);
    ASSERT_EQ(p.vertices.size(), 4u);
    EXPECT_EQ(o_x(p, 3), 3.0f);
    EXPECT_EQ(p.indices, (std::vector<std::uint32_t>{0, 1, 2, 2, 1, 3}));
    ASSERT_EQ(warnings.size(), 1u);
    EXPECT_NE(warnings[0].find("max_vertices = 4"), std::string::npos) << warnings[0];
    EXPECT_NE(warnings[0].find("primitive 7"), std::string::npos) << warnings[0];
}

TEST(ShaderGeometry, LineStripsAndPoints) {
    // lines in (2 vertices), a line strip of three vertices: lines (0 1), (1 2).
    const Module lines = geometry_module("layout(lines) in;\nlayout(line_strip, max_vertices = 3) out;",
                                         "o = v[0].value; EmitVertex();\n"
                                         "o = v[1].value; EmitVertex();\n"
                                         "o = v[0].value + v[1].value; EmitVertex();",
                                         2);
    EXPECT_EQ(lines.geometry_layout().input_vertices, 2);
    const ShaderPrimitives l = run(lines, 2);
    EXPECT_EQ(l.output, GeometryOutput::line_strip);
    ASSERT_EQ(l.vertices.size(), 3u);
    EXPECT_EQ(o_x(l, 2), 201.0f);  // 100 + 101
    EXPECT_EQ(l.indices, (std::vector<std::uint32_t>{0, 1, 1, 2}));
    // points in, points out: each vertex its own primitive, an EndPrimitive() between changes nothing.
    const Module points = geometry_module("layout(points) in;\nlayout(points, max_vertices = 2) out;",
                                          "o = v[0].value; EmitVertex(); EndPrimitive(); EmitVertex();", 1);
    EXPECT_EQ(points.geometry_layout().input_vertices, 1);
    EXPECT_EQ(points.geometry_layout().max_vertices, 2);
    const ShaderPrimitives q = run(points, 1);
    EXPECT_EQ(q.indices, (std::vector<std::uint32_t>{0, 1}));
    EXPECT_EQ(q.primitive_count(), 2u);
}

TEST(ShaderGeometry, PrimitiveIdAndInvocations) {
    // Two invocations, each emitting one triangle: o = (gl_PrimitiveIDIn, gl_InvocationID,
    // v[2].value.x, 0). Invocation 0's vertices come first; max_vertices counts per
    // invocation (3 each, 6 in all); each invocation's strip is its own.
    const Module m = geometry_module("layout(triangles, invocations = 2) in;\nlayout(triangle_strip, max_vertices = 3) out;",
                                     "for (int i = 0; i < 3; i++) {\n"
                                     "    o = vec4(float(gl_PrimitiveIDIn), float(gl_InvocationID), v[2].value.x, 0.0);\n"
                                     "    EmitVertex();\n"
                                     "}");
    EXPECT_EQ(m.geometry_layout().invocations, 2);
    const ShaderPrimitives p = run(m, 3, 41);
    ASSERT_EQ(p.vertices.size(), 6u);
    EXPECT_EQ(as_vec4(p.vertices[0].locations[0]), glm::vec4(41.0f, 0.0f, 102.0f, 0.0f));
    EXPECT_EQ(as_vec4(p.vertices[5].locations[0]), glm::vec4(41.0f, 1.0f, 102.0f, 0.0f));
    EXPECT_EQ(p.indices, (std::vector<std::uint32_t>{0, 1, 2, 3, 4, 5}));
}

TEST(ShaderGeometry, AdjacencyInputsAreRead) {
    // triangles_adjacency: six vertices; gl_in[5] is the last.
    const Module m = geometry_module("layout(triangles_adjacency) in;\nlayout(points, max_vertices = 1) out;",
                                     "gl_Position = gl_in[5].gl_Position; o = v[5].value; EmitVertex();", 6);
    EXPECT_EQ(m.geometry_layout().input_vertices, 6);
    const ShaderPrimitives p = run(m, 6);
    ASSERT_EQ(p.vertices.size(), 1u);
    EXPECT_EQ(p.vertices[0].position, glm::vec4(5.0f, 50.0f, 0.0f, 1.0f));
    EXPECT_EQ(o_x(p, 0), 105.0f);
}

TEST(ShaderGeometry, StreamsAreRefusedByName) {
    // EmitStreamVertex needs the GeometryStreams capability, which the interpreter refuses
    // when it loads the module, naming it.
    try {
        geometry_module("layout(points) in;\nlayout(points, max_vertices = 1) out;",
                        "o = v[0].value; EmitStreamVertex(0); EndStreamPrimitive(0);", 1);
        FAIL() << "no error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("GeometryStreams"), std::string::npos) << e.what();
        EXPECT_EQ(e.where().file, kPath);
    }
}

TEST(ShaderGeometry, OtherStagesHaveNoGeometryLayoutAndRunNoGeometry) {
    Source s;
    s.stage = ShaderStage::vertex;
    s.path = "x.vert";
    s.text = "#version 450 core\nvoid main() { gl_Position = vec4(1.0); }\n";
    const Module vert = Module::compile(s);
    EXPECT_THROW(vert.geometry_layout(), Error);
    const Executable e(vert, {}, {});
    EXPECT_THROW(e.geometry({}, 0), Error);
}

}  // namespace
}  // namespace tessref::shader

namespace tessref::shader {
namespace {

TEST(ShaderGeometry, AnEndlessInvocationRunsIntoTheBudgetNamingThePrimitive) {
    const Module m = geometry_module("layout(triangles) in;\nlayout(triangle_strip, max_vertices = 3) out;",
                                     "float s = 0.0;\nwhile (v[0].value.x > 0.0) s += 1.0;\no = vec4(s); EmitVertex();");
    RunOptions options;
    options.max_instructions = 10000;
    const Executable e(m, {}, options);
    const std::vector<ShaderVertex> in = inputs(3);
    try {
        e.geometry(in, 12);
        FAIL() << "no error";
    } catch (const Error& error) {
        const std::string what = error.what();
        EXPECT_NE(what.find("geometry shader snippet.geom, primitive 12, invocation 0"), std::string::npos) << what;
        EXPECT_NE(what.find("10000"), std::string::npos) << what;
        EXPECT_EQ(error.where().file, kPath);
    }
}

TEST(ShaderGeometry, ABatchOfPrimitivesGivesEachPrimitivesOwnResult) {
    // The pipeline's call: 150 primitives over a shared vertex array (more than two full
    // batches), through a shader whose lanes part ways: primitives whose first value is
    // even emit nothing, the others one triangle, or two strips when the value is 1 mod 4,
    // and a loop runs as many times as the value mod 5. Each primitive's result must be
    // the one-primitive call's, bit for bit, vertex for vertex.
    const Module m = geometry_module("layout(triangles, invocations = 2) in;\nlayout(triangle_strip, max_vertices = 6) out;",
                                     "int k = int(v[0].value.x);\n"
                                     "if (k % 2 == 0) return;\n"
                                     "float s = 0.0;\n"
                                     "for (int j = 0; j < k % 5; j++) s += sqrt(v[j % 3].value.x);\n"
                                     "for (int i = 0; i < 3; i++) {\n"
                                     "    gl_Position = gl_in[i].gl_Position * s;\n"
                                     "    o = vec4(v[i].value.x, s, float(gl_InvocationID), float(gl_PrimitiveIDIn));\n"
                                     "    EmitVertex();\n"
                                     "}\n"
                                     "EndPrimitive();\n"
                                     "if (k % 4 == 1) {\n"
                                     "    for (int i = 2; i >= 0; i--) { gl_Position = gl_in[i].gl_Position; o = v[i].value; EmitVertex(); }\n"
                                     "}");
    constexpr std::size_t kPrimitives = 150, kVertices = 160;
    ShaderVertices flat;
    flat.location_count = 1;
    for (std::size_t k = 0; k < kVertices; ++k) {
        flat.positions.push_back(glm::vec4(static_cast<float>(k), 0.25f * static_cast<float>(k), 1.0f, 1.0f));
        flat.locations.push_back(slot(glm::vec4(static_cast<float>(k % 37), 0.0f, 0.0f, 0.0f)));
    }
    std::vector<std::uint32_t> indices;
    for (std::size_t p = 0; p < kPrimitives; ++p)
        for (std::size_t j = 0; j < 3; ++j) indices.push_back(static_cast<std::uint32_t>((p * 7 + j * 3) % kVertices));
    const Executable e(m, {}, RunOptions{});
    std::vector<ShaderPrimitives> batched;
    e.geometry(flat, indices, 9, batched);
    ASSERT_EQ(batched.size(), kPrimitives);
    std::size_t emitting = 0, twice = 0;
    for (std::size_t p = 0; p < kPrimitives; ++p) {
        const std::vector<ShaderVertex> in = {flat.vertex(indices[3 * p]), flat.vertex(indices[3 * p + 1]),
                                              flat.vertex(indices[3 * p + 2])};
        const ShaderPrimitives one = e.geometry(in, 9);
        ASSERT_EQ(batched[p].vertices.size(), one.vertices.size()) << "primitive " << p;
        EXPECT_EQ(batched[p].indices, one.indices) << "primitive " << p;
        for (std::size_t k = 0; k < one.vertices.size(); ++k) {
            EXPECT_EQ(batched[p].vertices[k].position, one.vertices[k].position) << "primitive " << p;
            EXPECT_EQ(batched[p].vertices[k].locations, one.vertices[k].locations) << "primitive " << p;
        }
        emitting += one.vertices.empty() ? 0 : 1;
        twice += one.primitive_count() == 4 ? 1 : 0;  // two invocations of two triangles
    }
    // The three ways were all taken.
    EXPECT_GT(emitting, 0u);
    EXPECT_LT(emitting, kPrimitives);
    EXPECT_GT(twice, 0u);
}

}  // namespace
}  // namespace tessref::shader
