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

}  // namespace
}  // namespace tessref::shader
