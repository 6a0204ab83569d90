#version 450 core
// A user's evaluation shader: data/shaders/thesis_terrain.tese with every vertex raised by
// one unit of height (the `+ 1.0` below), the kind of bug `tessref compare` against
// `tessref render` must catch (test_gl_backend.cpp, docs/CLI.md, "Debugging your own shader").

layout(quads, fractional_odd_spacing, ccw) in;

layout(location = 0) in ControlData {
    vec4 tcPosition;
} controlIn[];

layout(location = 0) out EvaluationData {
    vec2 textureCoordinate;
} evaluationOut;

layout(binding = 0) uniform sampler2D heightMap;
uniform mat4 mvp;
uniform float scaleXY;
uniform float scaleZ;

void main()
{
    // The positions on the ad and the bc vectors.
    vec4 adPosition = mix(controlIn[0].tcPosition, controlIn[3].tcPosition, gl_TessCoord.x);
    vec4 bcPosition = mix(controlIn[1].tcPosition, controlIn[2].tcPosition, gl_TessCoord.x);

    // Then the position between the adPosition and the bcPosition point.
    vec4 position = mix(adPosition, bcPosition, gl_TessCoord.y);

    // Texture coordinate from the position and the scale in the xy plane.
    evaluationOut.textureCoordinate = position.xy / scaleXY;

    // The height map value times the z scale is the height.
    float height = texture(heightMap, evaluationOut.textureCoordinate).r * scaleZ + 1.0;

    vec4 positionWithHeight = vec4(position.x, position.y, height, 1.0);

    gl_Position = mvp * positionWithHeight;
}
