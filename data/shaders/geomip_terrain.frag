#version 450 core
// geomip_terrain.frag — the geomorphing article's terrain shading ("Materials"): the light
// map, material passes alpha-blended by their alpha maps, and the moving cloud shadows, in
// one fragment (the article draws one render pass per material into the framebuffer; the
// blend here is the same in float). GLSL 4.50 core. C++ twin: tessref::geomip_lightmap
// (src/shading/shading.cpp).

layout(location = 0) in GeometryData {
    vec3 gNormal;
    vec2 gTextureCoordinate;
} geometryIn;

layout(location = 0) out vec4 fragment;

// Texture units: 4 the light map, 5..8 the materials (GL_REPEAT), 9..12 their alpha maps
// (the base pass, material 0, has none), 13 the clouds (GL_REPEAT).
layout(binding = 4) uniform sampler2D lightMap;
layout(binding = 5) uniform sampler2D materials[4];
layout(binding = 9) uniform sampler2D alphaMaps[4];
layout(binding = 13) uniform sampler2D clouds;

uniform int materialCount;          // 1..4
uniform float materialRepeat[4];    // tiles across the terrain (the texture matrix's scale)
uniform vec2 lightMapScale;         // uv -> st with texel centres on the height samples
uniform vec2 lightMapOffset;
uniform int cloudsEnabled;
uniform float cloudRepeat;
uniform vec2 cloudOffset;           // fract(velocity * time)

void main()
{
    vec2 uv = geometryIn.gTextureCoordinate;
    vec2 st = uv * lightMapScale + lightMapOffset;
    float light = texture(lightMap, st).r;

    // The base pass: the repeated material modulated by the light map.
    vec3 colour = texture(materials[0], uv * materialRepeat[0]).rgb * light;
    for (int i = 1; i < materialCount; ++i) {
        vec3 pass = texture(materials[i], uv * materialRepeat[i]).rgb * light;
        float alpha = texture(alphaMaps[i], st).r;
        colour = mix(colour, pass, alpha);
    }

    // The cloud pass, multiplied into the frame.
    if (cloudsEnabled != 0)
        colour = colour * texture(clouds, uv * cloudRepeat + cloudOffset).r;

    fragment = vec4(colour, 1.0);
}
