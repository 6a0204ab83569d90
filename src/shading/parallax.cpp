// parallax.cpp — normal mapping, parallax mapping and the self-shadow trace (parallax.h),
// and the shading model that combines them (shading.h, pom_shading). GLSL twin:
// data/shaders/pom.frag, whose lines the comments name.
#include "tessref/parallax.h"

#include <algorithm>
#include <cmath>

#include "tessref/shading.h"

namespace tessref {

UvDerivatives triangle_uv_derivatives(glm::vec3 p0, glm::vec3 p1, glm::vec3 p2, glm::vec2 uv0, glm::vec2 uv1,
                                      glm::vec2 uv2) {
    // GLSL: pom.frag:60-63 the same solve from dFdx/dFdy of position and uv (one triangle's
    // position and uv are affine, so its screen derivatives give these exactly up to rounding)
    const glm::vec3 e1 = p1 - p0, e2 = p2 - p0;
    const glm::vec2 d1 = uv1 - uv0, d2 = uv2 - uv0;
    const float r = d1.x * d2.y - d2.x * d1.y;
    UvDerivatives out;
    if (r == 0.0f || !std::isfinite(r)) return out;
    out.dPdu = (e1 * d2.y - e2 * d1.y) / r;
    out.dPdv = (e2 * d1.x - e1 * d2.x) / r;
    return out;
}

TangentFrame tangent_frame(glm::vec3 normal, const UvDerivatives& d) {
    TangentFrame f;
    // GLSL: pom.frag:64 v3Normal = normalize(v3NormalIn);
    f.normal = glm::normalize(normal);
    // GLSL: pom.frag:65 v3Tangent = v3dPdu - v3Normal * dot(v3Normal, v3dPdu);
    glm::vec3 t = d.dPdu - f.normal * glm::dot(f.normal, d.dPdu);
    float tt = glm::dot(t, t);
    if (!(tt > 0.0f) || !std::isfinite(tt)) {
        // GLSL: pom.frag:66-68 no usable dP/du: any direction in the tangent plane
        const glm::vec3 axis = std::abs(f.normal.x) < 0.9f ? glm::vec3(1.0f, 0.0f, 0.0f) : glm::vec3(0.0f, 0.0f, 1.0f);
        t = axis - f.normal * glm::dot(f.normal, axis);
    }
    // GLSL: pom.frag:69 v3Tangent = normalize(v3Tangent);
    f.tangent = glm::normalize(t);
    // GLSL: pom.frag:70 v3BiTangent = cross(v3Normal, v3Tangent);
    f.bitangent = glm::cross(f.normal, f.tangent);
    // GLSL: pom.frag:71 if (dot(v3BiTangent, v3dPdv) < 0.0) v3BiTangent = -v3BiTangent;
    if (glm::dot(f.bitangent, d.dPdv) < 0.0f) f.bitangent = -f.bitangent;
    return f;
}

glm::vec3 to_tangent_space(const TangentFrame& f, glm::vec3 d) {
    return glm::vec3(glm::dot(d, f.tangent), glm::dot(d, f.bitangent), glm::dot(d, f.normal));
}

glm::vec3 normal_map(const TangentFrame& f, const Texture* s2NormalTexture, glm::vec2 uv, glm::vec2 dx, glm::vec2 dy) {
    // GLSL: pom.frag:76 vec2 v2NormalMap = (textureGrad(s2NormalTexture, v2LocalUV, v2Dx, v2Dy).rg - 0.5) * 2.0;
    const glm::vec4 texel = textureGrad(s2NormalTexture, uv, dx, dy);
    const glm::vec2 v2NormalMap = (glm::vec2(texel) - 0.5f) * 2.0f;
    // GLSL: pom.frag:77 vec3 v3NormalMap = vec3(v2NormalMap, sqrt(max(1.0 - dot(v2NormalMap, v2NormalMap), 0.0)));
    const glm::vec3 v3NormalMap(v2NormalMap, std::sqrt(std::max(1.0f - glm::dot(v2NormalMap, v2NormalMap), 0.0f)));
    // GLSL: pom.frag:78 return normalize(mat3(v3Tangent, v3BiTangent, v3Normal) * v3NormalMap);
    return glm::normalize(glm::mat3(f.tangent, f.bitangent, f.normal) * v3NormalMap);
}

namespace {
constexpr std::pair<ParallaxMode, const char*> kModeNames[] = {{ParallaxMode::none, "none"},
                                                               {ParallaxMode::parallax, "parallax"},
                                                               {ParallaxMode::steep, "steep"},
                                                               {ParallaxMode::occlusion, "occlusion"}};

float height_at(const Texture* s2BumpTexture, glm::vec2 uv, glm::vec2 dx, glm::vec2 dy) {
    return textureGrad(s2BumpTexture, uv, dx, dy).r;
}
}  // namespace

const char* to_string(ParallaxMode mode) {
    for (const auto& [m, name] : kModeNames)
        if (m == mode) return name;
    return "unknown";
}

std::optional<ParallaxMode> parallax_mode_from_string(std::string_view name) {
    for (const auto& [m, n] : kModeNames)
        if (name == n) return m;
    return std::nullopt;
}

float parallax_layers(glm::vec3 v, const ParallaxParams& p) {
    // GLSL: pom.frag:93 float fNumLayers = roundEven(mix(fMaxLayers, fMinLayers, abs(v3TangentView.z)));
    const float t = std::abs(v.z);
    return std::nearbyint(p.fMaxLayers * (1.0f - t) + p.fMinLayers * t);
}

glm::vec2 parallax_uv(glm::vec3 v, glm::vec2 uv, const Texture* s2BumpTexture, glm::vec2 dx, glm::vec2 dy,
                      const ParallaxParams& p) {
    switch (p.mode) {
        case ParallaxMode::none: return uv;
        case ParallaxMode::parallax: {
            // GLSL: pom.frag:90 return v2UV - fBumpScale * v3TangentView.xy / v3TangentView.z * (1.0 - h);
            const float h = height_at(s2BumpTexture, uv, dx, dy);
            return uv - p.fBumpScale * glm::vec2(v) / v.z * (1.0f - h);
        }
        case ParallaxMode::steep:
        case ParallaxMode::occlusion: break;
    }
    const float fNumLayers = parallax_layers(v, p);
    // GLSL: pom.frag:95 float fLayerHeight = 1.0 / fNumLayers;
    const float fLayerHeight = 1.0f / fNumLayers;
    // GLSL: pom.frag:96 vec2 v2DTex = fBumpScale * v3TangentView.xy / (v3TangentView.z * fNumLayers);
    const glm::vec2 v2DTex = p.fBumpScale * glm::vec2(v) / (v.z * fNumLayers);
    // GLSL: pom.frag:98 vec2 v2CurrUV = v2UV;
    glm::vec2 v2CurrUV = uv;
    // GLSL: pom.frag:99 float fCurrHeight = textureGrad(s2BumpTexture, v2CurrUV, v2Dx, v2Dy).r;
    float fCurrHeight = height_at(s2BumpTexture, v2CurrUV, dx, dy);
    // GLSL: pom.frag:100-102 fViewHeight = 1, fLastHeight = 1, v2LastUV = v2UV (the tutorial leaves
    // v2LastUV unset; a break at layer 0 then mixes it with weight 0, which NaN would spoil)
    float fViewHeight = 1.0f;
    float fLastHeight = 1.0f;
    glm::vec2 v2LastUV = uv;
    // GLSL: pom.frag:103 for (int i = 0; i < int(fNumLayers); i++)
    const int layers = static_cast<int>(fNumLayers);
    for (int i = 0; i < layers; i++) {
        // GLSL: pom.frag:104 if (fCurrHeight >= fViewHeight) break;
        if (fCurrHeight >= fViewHeight) break;
        // GLSL: pom.frag:105-106
        fLastHeight = fCurrHeight;
        v2LastUV = v2CurrUV;
        // GLSL: pom.frag:107 fViewHeight -= fLayerHeight;
        fViewHeight -= fLayerHeight;
        // GLSL: pom.frag:108 v2CurrUV -= v2DTex;
        v2CurrUV -= v2DTex;
        // GLSL: pom.frag:109 fCurrHeight = textureGrad(s2BumpTexture, v2CurrUV, v2Dx, v2Dy).r;
        fCurrHeight = height_at(s2BumpTexture, v2CurrUV, dx, dy);
    }
    // GLSL: pom.frag:111 if (iParallaxMode == 2) return v2CurrUV;
    if (p.mode == ParallaxMode::steep) return v2CurrUV;
    // GLSL: pom.frag:112 float fNextHeight = fCurrHeight - fViewHeight;
    const float fNextHeight = fCurrHeight - fViewHeight;
    // GLSL: pom.frag:113 float fPrevHeight = fLastHeight - (fViewHeight + fLayerHeight);
    const float fPrevHeight = fLastHeight - (fViewHeight + fLayerHeight);
    // GLSL: pom.frag:114 float fWeight = fNextHeight / (fNextHeight - fPrevHeight);
    const float fWeight = fNextHeight / (fNextHeight - fPrevHeight);
    // GLSL: pom.frag:115 return mix(v2CurrUV, v2LastUV, fWeight);
    return v2CurrUV * (1.0f - fWeight) + v2LastUV * fWeight;
}

float parallax_shadow(glm::vec3 l, glm::vec2 uv, const Texture* s2BumpTexture, glm::vec2 dx, glm::vec2 dy,
                      const ParallaxParams& p) {
    // GLSL: pom.frag:120 if (!(v3TangentLight.z > 0.0)) return 0.0;
    if (!(l.z > 0.0f)) return 0.0f;
    // GLSL: pom.frag:121 float fRayHeight = textureGrad(s2BumpTexture, v2UV, v2Dx, v2Dy).r;
    float fRayHeight = height_at(s2BumpTexture, uv, dx, dy);
    // GLSL: pom.frag:122 float fStep = (1.0 - fRayHeight) / fShadowLayers;
    const float fStep = (1.0f - fRayHeight) / p.fShadowLayers;
    // GLSL: pom.frag:123 vec2 v2DTex = fBumpScale * v3TangentLight.xy / v3TangentLight.z * fStep;
    const glm::vec2 v2DTex = p.fBumpScale * glm::vec2(l) / l.z * fStep;
    glm::vec2 v2CurrUV = uv;
    // GLSL: pom.frag:125 for (int i = 0; i < int(fShadowLayers); i++)
    const int steps = static_cast<int>(p.fShadowLayers);
    for (int i = 0; i < steps; i++) {
        // GLSL: pom.frag:126-127
        fRayHeight += fStep;
        v2CurrUV += v2DTex;
        // GLSL: pom.frag:128 if (textureGrad(s2BumpTexture, v2CurrUV, v2Dx, v2Dy).r > fRayHeight) return 0.0;
        if (height_at(s2BumpTexture, v2CurrUV, dx, dy) > fRayHeight) return 0.0f;
    }
    return 1.0f;
}

glm::vec4 pom_shading(const FragmentInputs& fragment, const PomShading& u, const ShadingTextures& textures) {
    // GLSL: pom.frag:137 tangentFrame(...) (lines 58-72)
    const TangentFrame frame = tangent_frame(fragment.normal, {fragment.dPdu, fragment.dPdv});
    // GLSL: pom.frag:135-136 the tiled uv and its derivatives
    const glm::vec2 v2UVIn = fragment.texCoord * u.fUvRepeat;
    const glm::vec2 v2Dx = fragment.texCoord_dx * u.fUvRepeat, v2Dy = fragment.texCoord_dy * u.fUvRepeat;
    // GLSL: pom.frag:138 vec3 v3View = normalize(v3CameraPosition - POSITION_IN);
    const glm::vec3 v3View = glm::normalize(u.v3CameraPosition - fragment.worldPosition);
    // GLSL: pom.frag:139 vec3 v3Light = normalize(v3LightDirection);
    const glm::vec3 v3Light = glm::normalize(u.v3LightDirection);
    // GLSL: pom.frag:140 vec2 v2UV = parallaxMap(normalize(toTangent(v3View)), v2UVIn);
    const glm::vec2 v2UV = parallax_uv(glm::normalize(to_tangent_space(frame, v3View)), v2UVIn,
                                       textures.s2BumpTexture.get(), v2Dx, v2Dy, u.parallax);
    // GLSL: pom.frag:141 vec3 v3MappedNormal = normalMap(v2UV);
    const glm::vec3 v3MappedNormal = normal_map(frame, textures.s2NormalTexture.get(), v2UV, v2Dx, v2Dy);
    // GLSL: pom.frag:142 float fShadow = bSelfShadow ? parallaxShadow(normalize(toTangent(v3Light)), v2UV) : 1.0;
    const float fShadow = u.bSelfShadow ? parallax_shadow(glm::normalize(to_tangent_space(frame, v3Light)), v2UV,
                                                          textures.s2BumpTexture.get(), v2Dx, v2Dy, u.parallax)
                                        : 1.0f;
    // GLSL: pom.frag:143 vec3 v3Albedo = v3DiffuseColour * textureGrad(s2DiffuseTexture, v2UV, v2Dx, v2Dy).rgb;
    const glm::vec3 v3Albedo = u.v3DiffuseColour * glm::vec3(textureGrad(textures.s2DiffuseTexture.get(), v2UV, v2Dx, v2Dy));
    // GLSL: pom.frag:144 vec3 v3Half = normalize(v3Light + v3View);
    const glm::vec3 v3Half = glm::normalize(v3Light + v3View);
    // GLSL: pom.frag:145 float fDiffuse = max(dot(v3MappedNormal, v3Light), 0.0) * fShadow;
    const float fDiffuse = std::max(glm::dot(v3MappedNormal, v3Light), 0.0f) * fShadow;
    // GLSL: pom.frag:146 float fSpecular = pow(max(dot(v3MappedNormal, v3Half), 0.0), fShininess) * fShadow;
    const float fSpecular = std::pow(std::max(glm::dot(v3MappedNormal, v3Half), 0.0f), u.fShininess) * fShadow;
    // GLSL: pom.frag:147 v4ColourOut = vec4(v3Albedo * (0.1 + 0.9 * fDiffuse) + vec3(0.3 * fSpecular), 1.0);
    return glm::vec4(v3Albedo * (0.1f + 0.9f * fDiffuse) + glm::vec3(0.3f * fSpecular), 1.0f);
}

}  // namespace tessref
