// The fragment stage: CPU twins of data/shaders/*.frag, in float, with the shaders' names
// and operations in the shaders' order. Each block points at the GLSL line it mirrors.
#include "tessref/shading.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>

#include "tessref/error.h"

namespace tessref {

namespace {

// A vec2 with the screen-space derivatives a fragment shader's texture() takes its lod from.
// Arithmetic on it carries the derivatives along (dFdx is linear), so the twins below can
// write texture(sampler, coordinate * 20) as the GLSL does.
struct FragmentCoord {
    glm::vec2 P{0.0f};
    glm::vec2 dPdx{0.0f};
    glm::vec2 dPdy{0.0f};
};

FragmentCoord operator*(const FragmentCoord& c, float k) { return {c.P * k, c.dPdx * k, c.dPdy * k}; }

// (vec4(P, 1, 1) * M).xy: the row vector times the matrix; its derivatives lose the constant
// 1s (the derivative of vec4(P, 1, 1) is vec4(dP, 0, 0)).
FragmentCoord row_times(const FragmentCoord& c, const glm::mat4& M) {
    return {glm::vec2(glm::vec4(c.P, 1.0f, 1.0f) * M), glm::vec2(glm::vec4(c.dPdx, 0.0f, 0.0f) * M),
            glm::vec2(glm::vec4(c.dPdy, 0.0f, 0.0f) * M)};
}

// GLSL texture(sampler, P) in a fragment shader.
glm::vec4 texture(const std::shared_ptr<const Texture>& sampler, const FragmentCoord& c) {
    return textureGrad(sampler.get(), c.P, c.dPdx, c.dPdy);
}

FragmentCoord texture_coordinate(const FragmentInputs& fragment) {
    return {fragment.texCoord, fragment.texCoord_dx, fragment.texCoord_dy};
}

constexpr std::array<std::string_view, 1> kThesisSingleSamplers{"diffuse"};
constexpr std::array<std::string_view, 11> kThesisMultiSamplers{
    "diffuse",           "canyon_rock01",        "canyon_rock02", "dry_grass09",
    "dry_grass12",       "romanian_sand05",      "VertRock_0_90_mask",
    "VertDetail_0_90_mask", "Grass_mask",        "Flow_mask",     "AmbientOcc"};
constexpr std::array<std::string_view, 1> kCosc422Samplers{"heightMap"};
constexpr std::array<std::string_view, 3> kPomSamplers{"s2DiffuseTexture", "s2NormalTexture", "s2BumpTexture"};

constexpr std::array<std::pair<ShadingKind, const char*>, 9> kKindNames{{
    {ShadingKind::flat, "flat"},
    {ShadingKind::depth, "depth"},
    {ShadingKind::thesis_single, "thesis_single"},
    {ShadingKind::thesis_multi, "thesis_multi"},
    {ShadingKind::lab4, "lab4"},
    {ShadingKind::cosc422, "cosc422"},
    {ShadingKind::pn, "pn"},
    {ShadingKind::geomip_lightmap, "geomip_lightmap"},
    {ShadingKind::pom, "pom"},
}};

}  // namespace

const char* to_string(ShadingKind kind) {
    for (const auto& [k, name] : kKindNames)
        if (k == kind) return name;
    return "unknown";
}

std::optional<ShadingKind> shading_kind_from_string(std::string_view name) {
    for (const auto& [k, n] : kKindNames)
        if (name == n) return k;
    return std::nullopt;
}

FragmentNeeds fragment_needs(ShadingKind kind) {
    FragmentNeeds needs;
    switch (kind) {
        case ShadingKind::flat: break;
        case ShadingKind::depth: needs.depth = true; break;
        case ShadingKind::thesis_single:
        case ShadingKind::thesis_multi:
        case ShadingKind::cosc422:
            needs.normal = needs.texCoord = needs.texCoord_derivatives = true;
            break;
        case ShadingKind::lab4:
        case ShadingKind::pn: needs.worldPosition = needs.normal = true; break;
        case ShadingKind::geomip_lightmap: needs.texCoord = needs.texCoord_derivatives = true; break;
        case ShadingKind::pom:
            needs.worldPosition = needs.normal = needs.texCoord = needs.texCoord_derivatives = true;
            needs.uv_derivatives = true;
            break;
    }
    return needs;
}

glm::mat4 thesis_default_rotation_matrix() {
    // Columns of M; (vec4(s, t, 1, 1) * M).x = dot(v, M[0]) = t, .y = dot(v, M[1]) = 1 - s.
    // Exact entries (no cos(pi/2) rounding residue).
    glm::mat4 M(0.0f);
    M[0] = glm::vec4(0.0f, 1.0f, 0.0f, 0.0f);
    M[1] = glm::vec4(-1.0f, 0.0f, 0.0f, 1.0f);
    M[2] = glm::vec4(0.0f, 0.0f, 1.0f, 0.0f);
    M[3] = glm::vec4(0.0f, 0.0f, 0.0f, 1.0f);
    return M;
}

std::span<const std::string_view> sampler_names(ShadingKind kind) {
    switch (kind) {
        case ShadingKind::thesis_single: return kThesisSingleSamplers;
        case ShadingKind::thesis_multi: return kThesisMultiSamplers;
        case ShadingKind::cosc422: return kCosc422Samplers;
        case ShadingKind::pom: return kPomSamplers;
        default: return {};
    }
}

std::shared_ptr<const Texture>* sampler_slot(ShadingTextures& t, std::string_view name) {
    if (name == "diffuse") return &t.diffuse;
    if (name == "canyon_rock01") return &t.canyon_rock01;
    if (name == "canyon_rock02") return &t.canyon_rock02;
    if (name == "dry_grass09") return &t.dry_grass09;
    if (name == "dry_grass12") return &t.dry_grass12;
    if (name == "romanian_sand05") return &t.romanian_sand05;
    if (name == "VertRock_0_90_mask") return &t.VertRock_0_90_mask;
    if (name == "VertDetail_0_90_mask") return &t.VertDetail_0_90_mask;
    if (name == "Grass_mask") return &t.Grass_mask;
    if (name == "Flow_mask") return &t.Flow_mask;
    if (name == "AmbientOcc") return &t.AmbientOcc;
    if (name == "heightMap") return &t.heightMap;
    if (name == "s2DiffuseTexture") return &t.s2DiffuseTexture;
    if (name == "s2NormalTexture") return &t.s2NormalTexture;
    if (name == "s2BumpTexture") return &t.s2BumpTexture;
    return nullptr;
}

const std::shared_ptr<const Texture>* sampler_slot(const ShadingTextures& t, std::string_view name) {
    return sampler_slot(const_cast<ShadingTextures&>(t), name);
}

std::vector<std::string_view> missing_textures(const ShadingModel& model) {
    std::vector<std::string_view> missing;
    for (std::string_view name : sampler_names(model.kind)) {
        const std::shared_ptr<const Texture>* slot = sampler_slot(model.textures, name);
        if (slot == nullptr || *slot == nullptr || (*slot)->empty()) missing.push_back(name);
    }
    return missing;
}

// ---- texture lookups -----------------------------------------------------------------------

float fast_log2(float x) {
    // lp_build_fast_log2: (exponent field - 128) + mantissa with the exponent forced to 0,
    // i.e. floor(log2 x) + (x / 2^floor(log2 x) - 1), one float add.
    const std::uint32_t bits = std::bit_cast<std::uint32_t>(x);
    const int ipart = static_cast<int>((bits >> 23) & 0xFFu) - 128;
    const float fpart = std::bit_cast<float>((bits & 0x007FFFFFu) | 0x3F800000u);
    return static_cast<float>(ipart) + fpart;
}

float fragment_lod(const Texture& sampler, glm::vec2 dPdx, glm::vec2 dPdy) {
    // llvmpipe (lp_build_rho, lp_build_lod_selector; no rho approximation, no brilinear):
    // the derivatives in texels, squared lengths, the longer one, lod = 0.5 * fast_log2.
    const glm::vec2 size(static_cast<float>(sampler.width()), static_cast<float>(sampler.height()));
    const glm::vec2 dx = dPdx * size;
    const glm::vec2 dy = dPdy * size;
    const float rho_x_squared = dx.x * dx.x + dx.y * dx.y;
    const float rho_y_squared = dy.x * dy.x + dy.y * dy.y;
    return 0.5f * fast_log2(std::max(rho_x_squared, rho_y_squared));
}

glm::vec4 textureGrad(const Texture* sampler, glm::vec2 P, glm::vec2 dPdx, glm::vec2 dPdy) {
    // GL 4.5 section 11.1.3.5: an incomplete (here: absent) texture samples as (0, 0, 0, 1).
    if (sampler == nullptr || sampler->empty()) return glm::vec4(0.0f, 0.0f, 0.0f, 1.0f);
    return sampler->textureLod(P, fragment_lod(*sampler, dPdx, dPdy));
}

namespace {

// textureGrad(sampler, texCoord, texCoord_dx, texCoord_dy) of up to four fragments: those
// whose lod reads level 0 alone sampled in one many-point texture() call, the others one by
// one.
void texture_of_fragments(const Texture* sampler, std::span<const FragmentInputs> fragments, glm::vec4* out) {
    if (sampler == nullptr || sampler->empty()) {
        for (std::size_t k = 0; k < fragments.size(); ++k) out[k] = textureGrad(sampler, {}, {}, {});
        return;
    }
    glm::vec2 st[4];
    glm::vec4 sample[4];
    std::size_t level0[4], count = 0;
    for (std::size_t k = 0; k < fragments.size(); ++k) {
        const FragmentInputs& f = fragments[k];
        const float lod = fragment_lod(*sampler, f.texCoord_dx, f.texCoord_dy);
        if (sampler->reads_level0_only(lod)) {
            st[count] = f.texCoord;
            level0[count++] = k;
        } else {
            out[k] = sampler->textureLod(f.texCoord, lod);
        }
    }
    sampler->texture(std::span<const glm::vec2>(st, count), std::span<glm::vec4>(sample, count));
    for (std::size_t j = 0; j < count; ++j) out[level0[j]] = sample[j];
}

}  // namespace

// ---- the thesis (Jakobsen 2012): listing 3, appendix A.5 and A.6 ---------------------------

namespace {

// The specular term's half vector, normalize(lightPosition + vec3(0, 0, 1)): a function of
// the uniforms alone, which the GLSL computes per fragment; shading many fragments computes
// it once (the same value, so the same bits).
glm::vec3 thesis_half_vector(const ThesisLight& uniforms) {
    return glm::normalize(uniforms.lightPosition + glm::vec3(0.0f, 0.0f, 1.0f));
}

glm::vec3 thesis_light(glm::vec3 gNormal, glm::vec3 ambient, const ThesisLight& uniforms, glm::vec3 half) {
    const glm::vec3& lightPosition = uniforms.lightPosition;
    // GLSL: thesis_terrain.frag:40 (thesis_terrain_single.frag:27) vec3 h = normalize(
    // lightPosition + vec3(0, 0, 1)); — the thesis's own line computes h and never reads it,
    // so it is left out here (its normalize cost a square root and a division per fragment).
    // GLSL: thesis_terrain.frag:41 float df = abs(dot(gNormal, lightPosition));
    // Quirk kept: lightPosition is used as a direction, unnormalized, so df scales with its
    // length; abs() lights a normal facing away from the light as one facing it.
    const float df = std::abs(glm::dot(gNormal, lightPosition));
    // GLSL: thesis_terrain.frag:42 float sf = abs(dot(gNormal, normalize(lightPosition +
    // vec3(0, 0, 1)))); — a half vector with a fixed eye direction +z; abs() again.
    float sf = std::abs(glm::dot(gNormal, half));
    // GLSL: thesis_terrain.frag:43 sf = pow(sf, shininess);
    sf = std::pow(sf, uniforms.shininess);
    // GLSL: thesis_terrain.frag:45 vec3 light = texture(AmbientOcc, ...).rgb + df *
    // diffuseMaterial + sf * specularMaterial; (thesis_terrain_single.frag:32 ambientMaterial + ...)
    return ambient + df * uniforms.diffuseMaterial + sf * uniforms.specularMaterial;
}


// thesis_terrain_single.frag with its texture lookup's value given (shade() of many fragments
// takes the lookups together).
glm::vec4 thesis_single_texture(const FragmentInputs& fragment, const ThesisLight& uniforms, glm::vec3 half,
                                const glm::vec4& diffuseTexture) {
    // GLSL: thesis_terrain_single.frag:25 vec3 gNormal = geometryIn.gNormal;
    const glm::vec3 gNormal = fragment.normal;
    // GLSL: thesis_terrain_single.frag:27-32 (listing 3) vec3 light = ambientMaterial + ...
    const glm::vec3 light = thesis_light(gNormal, uniforms.ambientMaterial, uniforms, half);
    // GLSL: thesis_terrain_single.frag:34 vec4 diffuseTexture = texture(diffuse, gTextureCoordinate);
    // (the caller's)
    // GLSL: thesis_terrain_single.frag:36 vec4 fragmentColour = diffuseTexture;
    glm::vec4 fragmentColour = diffuseTexture;
    // GLSL: thesis_terrain_single.frag:38 fragmentColour *= vec4(light, 1);
    fragmentColour *= glm::vec4(light, 1.0f);
    // GLSL: thesis_terrain_single.frag:40 fragment = fragmentColour; (lost from the appendix's
    // listing, restored in the shader)
    return fragmentColour;
}

}  // namespace

glm::vec3 thesis_light(glm::vec3 gNormal, glm::vec3 ambient, const ThesisLight& uniforms) {
    return thesis_light(gNormal, ambient, uniforms, thesis_half_vector(uniforms));
}

glm::vec4 thesis_single_texture(const FragmentInputs& fragment, const ThesisLight& uniforms,
                                const Texture* diffuse) {
    return thesis_single_texture(fragment, uniforms, thesis_half_vector(uniforms),
                                 textureGrad(diffuse, fragment.texCoord, fragment.texCoord_dx, fragment.texCoord_dy));
}

glm::vec4 thesis_multi_texture(const FragmentInputs& fragment, const ThesisLight& uniforms,
                               const glm::mat4& rotationMatrix, const ShadingTextures& t) {
    // GLSL: thesis_terrain.frag:37-38
    const glm::vec3 gNormal = fragment.normal;
    const FragmentCoord gTextureCoordinate = texture_coordinate(fragment);

    // GLSL: thesis_terrain.frag:40-45 (listing 3 with the AmbientOcc texture as ambient)
    const glm::vec3 light = thesis_light(gNormal, glm::vec3(texture(t.AmbientOcc, gTextureCoordinate)), uniforms);

    // GLSL: thesis_terrain.frag:47 vec4 diffuseTexture = texture(diffuse, gTextureCoordinate);
    const glm::vec4 diffuseTexture = texture(t.diffuse, gTextureCoordinate);

    // GLSL: thesis_terrain.frag:50 vec2 textureCoordinate90 = (vec4(gTextureCoordinate, 1, 1) *
    // rotationMatrix).xy;
    const FragmentCoord textureCoordinate90 = row_times(gTextureCoordinate, rotationMatrix);

    // GLSL: thesis_terrain.frag:52-54 textureRock (VertRock_0_90_mask picks rotated/unrotated)
    const glm::vec4 textureRock = glm::mix(texture(t.canyon_rock01, textureCoordinate90 * 20.0f),
                                           texture(t.canyon_rock01, gTextureCoordinate * 20.0f),
                                           texture(t.VertRock_0_90_mask, gTextureCoordinate).r);
    // GLSL: thesis_terrain.frag:55-57 textureRock2
    const glm::vec4 textureRock2 = glm::mix(texture(t.canyon_rock02, textureCoordinate90 * 10.0f),
                                            texture(t.canyon_rock02, gTextureCoordinate * 10.0f),
                                            texture(t.VertRock_0_90_mask, gTextureCoordinate).r);
    // GLSL: thesis_terrain.frag:59-61 texturegrass1
    const glm::vec4 texturegrass1 = glm::mix(texture(t.dry_grass12, textureCoordinate90 * 50.0f),
                                             texture(t.dry_grass12, gTextureCoordinate * 50.0f),
                                             texture(t.VertDetail_0_90_mask, gTextureCoordinate).r);
    // GLSL: thesis_terrain.frag:62-64 texturegrass2
    const glm::vec4 texturegrass2 = glm::mix(texture(t.dry_grass09, textureCoordinate90 * 100.0f),
                                             texture(t.dry_grass09, gTextureCoordinate * 100.0f),
                                             texture(t.VertDetail_0_90_mask, gTextureCoordinate).r);
    // GLSL: thesis_terrain.frag:65-67 texturesand
    const glm::vec4 texturesand = glm::mix(texture(t.romanian_sand05, textureCoordinate90 * 50.0f),
                                           texture(t.romanian_sand05, gTextureCoordinate * 50.0f),
                                           texture(t.VertDetail_0_90_mask, gTextureCoordinate).r);

    // GLSL: thesis_terrain.frag:69 vec4 fragmentColour = diffuseTexture;
    glm::vec4 fragmentColour = diffuseTexture;
    // GLSL: thesis_terrain.frag:71-72 the two rock layers, constant weights
    fragmentColour = glm::mix(fragmentColour, textureRock, 0.8f);
    fragmentColour = glm::mix(fragmentColour, textureRock2, 0.5f);
    // GLSL: thesis_terrain.frag:74-75 the grass layers under Grass_mask (the second at half)
    fragmentColour = glm::mix(fragmentColour, texturegrass1, texture(t.Grass_mask, gTextureCoordinate).r);
    fragmentColour = glm::mix(fragmentColour, texturegrass2, texture(t.Grass_mask, gTextureCoordinate).r / 2.0f);
    // GLSL: thesis_terrain.frag:77 sand under Flow_mask
    fragmentColour = glm::mix(fragmentColour, texturesand, texture(t.Flow_mask, gTextureCoordinate).r);
    // GLSL: thesis_terrain.frag:79 fragmentColour *= vec4(light, 1);
    fragmentColour *= glm::vec4(light, 1.0f);
    // GLSL: thesis_terrain.frag:81 fragment = fragmentColour;
    return fragmentColour;
}

// ---- lab 4 ---------------------------------------------------------------------------------

Lab4Weights lab4_weights(glm::vec3 worldPosition, glm::vec3 normal, const Lab4Shading& u) {
    Lab4Weights w;
    // GLSL: lab4_terrain.frag:23 vec3 n = normalize(evaluationIn.normal);
    const glm::vec3 n = glm::normalize(normal);
    // GLSL: lab4_terrain.frag:24 float heightWeight = smoothstep(sandHeight - blendWidth,
    // sandHeight + blendWidth, evaluationIn.worldPosition.y);
    w.heightWeight = glm::smoothstep(u.sandHeight - u.blendWidth, u.sandHeight + u.blendWidth, worldPosition.y);
    // GLSL: lab4_terrain.frag:26 float slopeWeight = 1.0 - smoothstep(0.6, 0.8, n.y);
    w.slopeWeight = 1.0f - glm::smoothstep(0.6f, 0.8f, n.y);
    // GLSL: lab4_terrain.frag:27 float rock = max(heightWeight, slopeWeight);
    w.rock = std::max(w.heightWeight, w.slopeWeight);
    // mix(sand, rock, rock) weighs sand by 1 - rock (GLSL mix is x * (1 - a) + y * a).
    w.sand = 1.0f - w.rock;
    return w;
}

glm::vec4 lab4_terrain(const FragmentInputs& fragment, const Lab4Shading& u) {
    // GLSL: lab4_terrain.frag:23 vec3 n = normalize(evaluationIn.normal);
    const glm::vec3 n = glm::normalize(fragment.normal);
    // GLSL: lab4_terrain.frag:24-27 heightWeight, slopeWeight, rock
    const float rock = lab4_weights(fragment.worldPosition, fragment.normal, u).rock;
    // GLSL: lab4_terrain.frag:28 vec3 albedo = mix(sandColour, rockColour, rock);
    const glm::vec3 albedo = glm::mix(u.sandColour, u.rockColour, rock);

    // GLSL: lab4_terrain.frag:30 vec3 l = normalize(lightDirection);
    const glm::vec3 l = glm::normalize(u.lightDirection);
    // GLSL: lab4_terrain.frag:31 vec3 viewDirection = normalize(cameraPosition - worldPosition);
    const glm::vec3 viewDirection = glm::normalize(u.cameraPosition - fragment.worldPosition);
    // GLSL: lab4_terrain.frag:32 vec3 halfVector = normalize(l + viewDirection);
    const glm::vec3 halfVector = glm::normalize(l + viewDirection);
    // GLSL: lab4_terrain.frag:33 float diffuseTerm = max(dot(n, l), 0.0);
    const float diffuseTerm = std::max(glm::dot(n, l), 0.0f);
    // GLSL: lab4_terrain.frag:34 per-material specular: exponent mix(8, 32, rock), strength
    // mix(0.05, 0.3, rock) (rock is glossier than sand)
    const float specularTerm = std::pow(std::max(glm::dot(n, halfVector), 0.0f), glm::mix(8.0f, 32.0f, rock)) *
                               glm::mix(0.05f, 0.3f, rock);
    // GLSL: lab4_terrain.frag:35 fragment = vec4(albedo * (0.15 + 0.85 * diffuseTerm) +
    // vec3(specularTerm), 1.0);
    return glm::vec4(albedo * (0.15f + 0.85f * diffuseTerm) + glm::vec3(specularTerm), 1.0f);
}

// ---- COSC422 -------------------------------------------------------------------------------

glm::vec4 cosc422_terrain(const FragmentInputs& fragment, const Cosc422Shading& u, const Texture* heightMap) {
    // GLSL: cosc422_terrain.frag:18 float diffuseTerm = max(dot(normalize(geometryIn.faceNormal),
    // normalize(lightDirection)), 0.0);
    const float diffuseTerm = std::max(glm::dot(glm::normalize(fragment.normal), glm::normalize(u.lightDirection)), 0.0f);
    // GLSL: cosc422_terrain.frag:19 vec3 albedo = vec3(texture(heightMap, geometryIn.texCoord).r * 0.5 + 0.5);
    const glm::vec3 albedo(textureGrad(heightMap, fragment.texCoord, fragment.texCoord_dx, fragment.texCoord_dy).r * 0.5f + 0.5f);
    // GLSL: cosc422_terrain.frag:20 outputColor = vec4(albedo * (ambient + (1.0 - ambient) * diffuseTerm), 1.0);
    return glm::vec4(albedo * (u.ambient + (1.0f - u.ambient) * diffuseTerm), 1.0f);
}

// ---- PN triangles --------------------------------------------------------------------------

glm::vec4 pn_triangles(const FragmentInputs& fragment, const PnShading& u) {
    // GLSL: pn_triangles.frag:21 vec3 v3Normal = normalize(evaluationIn.v3NormalOut);
    const glm::vec3 v3Normal = glm::normalize(fragment.normal);
    // GLSL: pn_triangles.frag:22 vec3 v3Light = normalize(v3LightDirection);
    const glm::vec3 v3Light = glm::normalize(u.v3LightDirection);
    // GLSL: pn_triangles.frag:23 vec3 v3View = normalize(v3CameraPosition - evaluationIn.v3PositionOut);
    const glm::vec3 v3View = glm::normalize(u.v3CameraPosition - fragment.worldPosition);
    // GLSL: pn_triangles.frag:24 vec3 v3Half = normalize(v3Light + v3View);
    const glm::vec3 v3Half = glm::normalize(v3Light + v3View);
    // GLSL: pn_triangles.frag:25 float fDiffuse = max(dot(v3Normal, v3Light), 0.0);
    const float fDiffuse = std::max(glm::dot(v3Normal, v3Light), 0.0f);
    // GLSL: pn_triangles.frag:26 float fSpecular = pow(max(dot(v3Normal, v3Half), 0.0), fShininess);
    const float fSpecular = std::pow(std::max(glm::dot(v3Normal, v3Half), 0.0f), u.fShininess);
    // GLSL: pn_triangles.frag:27 v4ColourOut = vec4(v3DiffuseColour * (0.1 + 0.9 * fDiffuse) +
    // vec3(0.3 * fSpecular), 1.0);
    return glm::vec4(u.v3DiffuseColour * (0.1f + 0.9f * fDiffuse) + glm::vec3(0.3f * fSpecular), 1.0f);
}

// ---- the geomorphing article's materials (geomip_terrain.frag) -----------------------------

glm::vec4 geomip_lightmap(const FragmentInputs& fragment, const GeomipLightmapShading& u) {
    // GLSL: geomip_terrain.frag:32 vec2 uv = geometryIn.gTextureCoordinate;
    const FragmentCoord uv = texture_coordinate(fragment);
    // "Materials": one light map spans the terrain, uv (0, 0) to (1, 1); its texels (and the
    // alpha maps') are centred on the height samples.
    // GLSL: geomip_terrain.frag:33 vec2 st = uv * lightMapScale + lightMapOffset;
    const FragmentCoord st{uv.P * u.lightMapScale + u.lightMapOffset, uv.dPdx * u.lightMapScale,
                           uv.dPdy * u.lightMapScale};
    // GLSL: geomip_terrain.frag:34 float light = texture(lightMap, st).r;
    const float light = texture(u.lightMap, st).r;
    glm::vec3 colour(0.0f);
    for (std::size_t i = 0; i < u.materials.size(); ++i) {
        const GeomipMaterial& m = u.materials[i];
        if (i == 0) {
            // The base pass: nothing drawn before it, no alpha map. Two texture stages,
            // modulated: the repeated material times the light map.
            // GLSL: geomip_terrain.frag:37 vec3 colour = texture(materials[0], uv * materialRepeat[0]).rgb * light;
            colour = glm::vec3(texture(m.texture, uv * m.repeat)) * light;
        } else {
            // GLSL: geomip_terrain.frag:39 vec3 pass = texture(materials[i], uv * materialRepeat[i]).rgb * light;
            const glm::vec3 pass = glm::vec3(texture(m.texture, uv * m.repeat)) * light;
            // Alpha-blended over the passes before it (SRC_ALPHA, ONE_MINUS_SRC_ALPHA), its
            // alpha from the material's alpha map.
            // GLSL: geomip_terrain.frag:40 float alpha = texture(alphaMaps[i], st).r;
            const float alpha = texture(m.alpha, st).r;
            // GLSL: geomip_terrain.frag:41 colour = mix(colour, pass, alpha);
            colour = colour + alpha * (pass - colour);
        }
    }
    // The cloud pass: the repeated shadow texture (grey: its red channel), its translation
    // moved with time, multiplied into the frame (DST_COLOR, ZERO).
    if (u.clouds) {
        const FragmentCoord cloud{uv.P * u.cloudRepeat + u.cloudOffset, uv.dPdx * u.cloudRepeat,
                                  uv.dPdy * u.cloudRepeat};
        // GLSL: geomip_terrain.frag:46 colour = colour * texture(clouds, uv * cloudRepeat + cloudOffset).r;
        colour = colour * texture(u.clouds, cloud).r;
    }
    // GLSL: geomip_terrain.frag:48 fragment = vec4(colour, 1.0);
    return glm::vec4(colour, 1.0f);
}

// ---- no shading ----------------------------------------------------------------------------

glm::vec4 flat_colour(const FlatShading& u) { return u.colour; }

glm::vec4 depth_colour(const FragmentInputs& fragment, const DepthShading& u) {
    if (u.mapping == DepthMapping::window) return glm::vec4(glm::vec3(fragment.depth), 1.0f);
    // Window depth d in [0, 1] -> NDC z = 2d - 1 -> eye distance of a GL perspective
    // projection: z_eye = 2 n f / (f + n - z_ndc (f - n)); then mapped linearly, n -> 0, f -> 1.
    // In double: a picture, not a GPU twin.
    const double n = u.near_plane;
    const double f = u.far_plane;
    const double z_ndc = 2.0 * static_cast<double>(fragment.depth) - 1.0;
    const double z_eye = 2.0 * n * f / (f + n - z_ndc * (f - n));
    const float grey = static_cast<float>((z_eye - n) / (f - n));
    return glm::vec4(glm::vec3(grey), 1.0f);
}

// ---- the entry point -----------------------------------------------------------------------

glm::vec4 shade(const ShadingModel& model, const FragmentInputs& fragment) {
    switch (model.kind) {
        case ShadingKind::flat: return flat_colour(model.flat);
        case ShadingKind::depth: return depth_colour(fragment, model.depth);
        case ShadingKind::thesis_single:
            return thesis_single_texture(fragment, model.thesis, model.textures.diffuse.get());
        case ShadingKind::thesis_multi:
            return thesis_multi_texture(fragment, model.thesis, model.rotationMatrix, model.textures);
        case ShadingKind::lab4: return lab4_terrain(fragment, model.lab4);
        case ShadingKind::cosc422: return cosc422_terrain(fragment, model.cosc422, model.textures.heightMap.get());
        case ShadingKind::pn: return pn_triangles(fragment, model.pn);
        case ShadingKind::geomip_lightmap: return geomip_lightmap(fragment, model.geomip);
        case ShadingKind::pom: return pom_shading(fragment, model.pom, model.textures);
    }
    return flat_colour(model.flat);
}

void shade(const ShadingModel& model, std::span<const FragmentInputs> fragments, std::span<glm::vec4> out) {
    if (fragments.size() != out.size()) throw Error("shade: as many colours as fragments");
    const glm::vec3 half = thesis_half_vector(model.thesis);
    for (std::size_t first = 0; first < fragments.size(); first += 4) {
        const auto some = fragments.subspan(first, std::min<std::size_t>(4, fragments.size() - first));
        if (model.kind == ShadingKind::thesis_single) {
            glm::vec4 diffuseTexture[4];
            texture_of_fragments(model.textures.diffuse.get(), some, diffuseTexture);
            for (std::size_t k = 0; k < some.size(); ++k)
                out[first + k] = thesis_single_texture(some[k], model.thesis, half, diffuseTexture[k]);
        } else {
            for (std::size_t k = 0; k < some.size(); ++k) out[first + k] = shade(model, some[k]);
        }
    }
}

}  // namespace tessref
