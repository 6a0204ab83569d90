#version 450 core
// pom.frag — the PN-triangles tutorial's normal mapping (part 1), parallax occlusion mapping
// (part 2) and the self-shadowing trace toward the light (its "super extra"), with
// pn_triangles.frag's light. GLSL 4.50 core. CPU twin: src/shading/parallax.cpp
// (tessref/parallax.h explains the formulas). Differences from the tutorial, each for a
// defined result: the tangent frame comes from dFdx/dFdy of position and uv (no tangent
// attribute) with a handedness sign; z of the normal map is sqrt(max(.., 0)); the layer
// count rounds half to even; v2LastUV starts at the unshifted uv.
// The evaluation stage's position, normal and uv: pn_triangles.tese's EvaluationData block,
// or with TERRAIN_NORMALS (tessref gl defines it for a cosc422 terrain with [geometry]
// normals = "height_field") the terrain block cosc422_terrain.tese then writes.

#ifdef TERRAIN_NORMALS
layout(location = 0) in EvaluationData {
    vec3 worldPosition;
    vec3 normal;
    vec2 texCoord;
} evaluationIn;
#define POSITION_IN evaluationIn.worldPosition
#define NORMAL_IN evaluationIn.normal
#define UV_IN evaluationIn.texCoord
#else
layout(location = 0) in EvaluationData {
    vec3 v3PositionOut;
    vec3 v3NormalOut;
    vec2 v2UVOut;
} evaluationIn;
#define POSITION_IN evaluationIn.v3PositionOut
#define NORMAL_IN evaluationIn.v3NormalOut
#define UV_IN evaluationIn.v2UVOut
#endif

layout(location = 0) out vec4 v4ColourOut;

layout(binding = 4) uniform sampler2D s2DiffuseTexture;
layout(binding = 5) uniform sampler2D s2NormalTexture;
layout(binding = 6) uniform sampler2D s2BumpTexture;

uniform vec3 v3CameraPosition;
uniform vec3 v3LightDirection = vec3(0.4, 0.8, 0.45);
uniform vec3 v3DiffuseColour = vec3(1.0);
uniform float fShininess = 32.0;
uniform int iParallaxMode = 3;        // 0 none, 1 parallax, 2 steep, 3 occlusion
uniform float fBumpScale = 0.05;
uniform float fMinLayers = 5.0;
uniform float fMaxLayers = 15.0;
uniform float fShadowLayers = 30.0;
uniform bool bSelfShadow = true;
uniform float fUvRepeat = 1.0;

vec3 v3Normal;
vec3 v3Tangent;
vec3 v3BiTangent;
vec2 v2Dx;
vec2 v2Dy;

// The uv derivatives dP/du, dP/dv from the screen-space ones, then Gram-Schmidt.
void tangentFrame(vec3 v3NormalIn, vec3 v3Position, vec2 v2UV)
{
    vec3 v3dPdx = dFdx(v3Position), v3dPdy = dFdy(v3Position);
    vec2 v2dUVdx = dFdx(v2UV), v2dUVdy = dFdy(v2UV);
    float r = v2dUVdx.x * v2dUVdy.y - v2dUVdy.x * v2dUVdx.y;
    vec3 v3dPdu = (v3dPdx * v2dUVdy.y - v3dPdy * v2dUVdx.y) / r, v3dPdv = (v3dPdy * v2dUVdx.x - v3dPdx * v2dUVdy.x) / r;
    v3Normal = normalize(v3NormalIn);
    v3Tangent = v3dPdu - v3Normal * dot(v3Normal, v3dPdu);
    if (!(dot(v3Tangent, v3Tangent) > 0.0) || isinf(dot(v3Tangent, v3Tangent)) || isnan(dot(v3Tangent, v3Tangent)))
        v3Tangent = (abs(v3Normal.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 0.0, 1.0))
                    - v3Normal * dot(v3Normal, abs(v3Normal.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 0.0, 1.0));
    v3Tangent = normalize(v3Tangent);
    v3BiTangent = cross(v3Normal, v3Tangent);
    if (dot(v3BiTangent, v3dPdv) < 0.0) v3BiTangent = -v3BiTangent;
}

vec3 normalMap(in vec2 v2LocalUV)
{
    vec2 v2NormalMap = (textureGrad(s2NormalTexture, v2LocalUV, v2Dx, v2Dy).rg - 0.5) * 2.0;
    vec3 v3NormalMap = vec3(v2NormalMap, sqrt(max(1.0 - dot(v2NormalMap, v2NormalMap), 0.0)));
    return normalize(mat3(v3Tangent, v3BiTangent, v3Normal) * v3NormalMap);
}

vec3 toTangent(vec3 v3Direction)
{
    return vec3(dot(v3Direction, v3Tangent), dot(v3Direction, v3BiTangent), dot(v3Direction, v3Normal));
}

vec2 parallaxMap(in vec3 v3TangentView, in vec2 v2UV)
{
    if (iParallaxMode == 0) return v2UV;
    float h = textureGrad(s2BumpTexture, v2UV, v2Dx, v2Dy).r;
    if (iParallaxMode == 1) return v2UV - fBumpScale * v3TangentView.xy / v3TangentView.z * (1.0 - h);

    // The number of layers from the view angle: more toward grazing.
    float fNumLayers = roundEven(mix(fMaxLayers, fMinLayers, abs(v3TangentView.z)));
    // The layer's height and its uv step.
    float fLayerHeight = 1.0 / fNumLayers;
    vec2 v2DTex = fBumpScale * v3TangentView.xy / (v3TangentView.z * fNumLayers);
    // Walk down until the height map is at or above the ray.
    vec2 v2CurrUV = v2UV;
    float fCurrHeight = textureGrad(s2BumpTexture, v2CurrUV, v2Dx, v2Dy).r;
    float fViewHeight = 1.0;
    float fLastHeight = 1.0;
    vec2 v2LastUV = v2UV;
    for (int i = 0; i < int(fNumLayers); i++) {
        if (fCurrHeight >= fViewHeight) break;
        fLastHeight = fCurrHeight;
        v2LastUV = v2CurrUV;
        fViewHeight -= fLayerHeight;
        v2CurrUV -= v2DTex;
        fCurrHeight = textureGrad(s2BumpTexture, v2CurrUV, v2Dx, v2Dy).r;
    }
    if (iParallaxMode == 2) return v2CurrUV;
    float fNextHeight = fCurrHeight - fViewHeight;
    float fPrevHeight = fLastHeight - (fViewHeight + fLayerHeight);
    float fWeight = fNextHeight / (fNextHeight - fPrevHeight);
    return mix(v2CurrUV, v2LastUV, fWeight);
}

float parallaxShadow(in vec3 v3TangentLight, in vec2 v2UV)
{
    if (!(v3TangentLight.z > 0.0)) return 0.0;
    float fRayHeight = textureGrad(s2BumpTexture, v2UV, v2Dx, v2Dy).r;
    float fStep = (1.0 - fRayHeight) / fShadowLayers;
    vec2 v2DTex = fBumpScale * v3TangentLight.xy / v3TangentLight.z * fStep;
    vec2 v2CurrUV = v2UV;
    for (int i = 0; i < int(fShadowLayers); i++) {
        fRayHeight += fStep;
        v2CurrUV += v2DTex;
        if (textureGrad(s2BumpTexture, v2CurrUV, v2Dx, v2Dy).r > fRayHeight) return 0.0;
    }
    return 1.0;
}

void main()
{
    vec2 v2UVIn = UV_IN * fUvRepeat;
    v2Dx = dFdx(v2UVIn); v2Dy = dFdy(v2UVIn);
    tangentFrame(NORMAL_IN, POSITION_IN, UV_IN);
    vec3 v3View = normalize(v3CameraPosition - POSITION_IN);
    vec3 v3Light = normalize(v3LightDirection);
    vec2 v2UV = parallaxMap(normalize(toTangent(v3View)), v2UVIn);
    vec3 v3MappedNormal = normalMap(v2UV);
    float fShadow = bSelfShadow ? parallaxShadow(normalize(toTangent(v3Light)), v2UV) : 1.0;
    vec3 v3Albedo = v3DiffuseColour * textureGrad(s2DiffuseTexture, v2UV, v2Dx, v2Dy).rgb;
    vec3 v3Half = normalize(v3Light + v3View);
    float fDiffuse = max(dot(v3MappedNormal, v3Light), 0.0) * fShadow;
    float fSpecular = pow(max(dot(v3MappedNormal, v3Half), 0.0), fShininess) * fShadow;
    v4ColourOut = vec4(v3Albedo * (0.1 + 0.9 * fDiffuse) + vec3(0.3 * fSpecular), 1.0);
}
