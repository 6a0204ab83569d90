#version 450 core
// geomip_terrain.vert — the vertex shader of geomipmapping with geomorphing (the
// geomorphing article's "Geomorphing in the vertex shader"), in GLSL 4.50 core. C++ twin:
// tessref::geomip::morph_height (src/geomipmap/geomipmap.cpp), run by
// src/pipeline/geomipmap.cpp for the gpu precision.
//
// The CPU did the rest, as the article's application does: the level of every patch, the
// adapting border triangles, the index and vertex buffers. Each vertex carries its true
// height and its height on the next coarser level's surface (the morph target), and the
// shader moves it between the two by its tween factor. The article keeps five tween
// factors per patch as shader constants (the patch's own and one per side) and lets each
// vertex pick its own; here the CPU writes the factor a vertex picks into its attribute, so
// that every patch goes into one draw with the same value.

layout(location = 0) in vec2 groundPosition;     // world x, y of the height sample
layout(location = 1) in float sampleHeight;      // its true height (map units)
layout(location = 2) in float morphTarget;       // its height on the next coarser level
layout(location = 3) in float tween;             // the patch's or its side's tween factor
layout(location = 4) in vec3 normal;             // the CPU geometry stage's normal (or zero)
layout(location = 5) in vec2 textureCoordinate;  // sample / (map size - 1)

layout(location = 0) out GeometryData {
    vec3 gNormal;
    vec2 gTextureCoordinate;
} vertexOut;

uniform mat4 mvp;
uniform float scaleZ;

void main()
{
    // The geomorph: from the true height toward the coarser level's, by the tween.
    float height = mix(sampleHeight, morphTarget, tween);

    vec4 position = vec4(groundPosition, height * scaleZ, 1.0);

    vertexOut.gNormal = normal;
    vertexOut.gTextureCoordinate = textureCoordinate;
    gl_Position = mvp * position;
}
