// tessref/shading.h — the fragment stage: one colour per fragment, on the CPU.
//
// Every model is the CPU twin of a fragment shader in data/shaders/, written with the
// shader's names and operations in the shader's order, in float (GPU-faithful):
//   ShadingKind      GLSL twin                      C++ function
//   thesis_single    thesis_terrain_single.frag     thesis_single_texture  (thesis app. A.6)
//   thesis_multi     thesis_terrain.frag            thesis_multi_texture   (thesis app. A.5)
//   lab4             lab4_terrain.frag              lab4_terrain           (lab 4, 2.6)
//   cosc422          cosc422_terrain.frag           cosc422_terrain        (COSC422 step 6)
//   pn               pn_triangles.frag              pn_triangles
//   pom              pom.frag                       pom_shading            (the PN-triangles
//                                                   tutorial's normal and parallax occlusion
//                                                   mapping; parallax.h)
//   flat, depth      (none: the "no shading" modes) flat_colour, depth_colour
//   geomip_lightmap  geomip_terrain.frag            geomip_lightmap        (the geomorphing
//                                                   article's light map, materials, clouds)
// and shade(model, fragment) dispatches on the kind. The light of the thesis's listing 3,
// shared by both thesis shaders, is thesis_light().
//
// The result is the shader's output as written (no clamping): the thesis's light can exceed
// 1; a unorm8 framebuffer clamps when it stores the value (raster.h, to_rgba8).
//
// TEXTURES. Texture lookups go through tessref::Texture (texture.h), i.e. clamp-to-edge,
// GL_LINEAR magnification and GL_LINEAR_MIPMAP_LINEAR minification on a glGenerateMipmap
// pyramid. A fragment shader's texture(sampler, P) takes its level of detail from the
// screen-space derivatives of P, so texture() here is GLSL's textureGrad(sampler, P,
// dFdx(P), dFdy(P)) with the derivatives carried in FragmentInputs (see fragment_lod for the
// formula). A sampler with no texture (a null pointer) reads (0, 0, 0, 1), as GL returns for
// a sampler whose texture is incomplete or unbound. Only the models that declare samplers
// read any (sampler_names); a scene that names no texture needs none: flat, depth, lab4 and
// pn never touch a texture, and nothing here loads one.
//
// QUIRKS KEPT (the thesis shaders, as the thesis's listing 3 and appendix A.5/A.6 have them):
//   - lightPosition is a POSITION by name but is used as a light DIRECTION, and unnormalized:
//     df = abs(dot(gNormal, lightPosition)) grows with |lightPosition|;
//   - abs() in df and sf: a normal facing away from the light is lit exactly like one facing
//     it (back faces and the far side of a hill are as bright as the sunny side);
//   - the specular half vector is normalize(lightPosition + (0, 0, 1)): a fixed eye direction
//     +z, whatever the camera; h is computed and never used (the expression is repeated);
//   - gNormal is used as interpolated, never renormalized (and the geometry stage applies
//     normalMatrix after normalizing, so it need not be unit length even at a vertex);
//   - the multi-texture shader declares ambientMaterial but uses the AmbientOcc texture in
//     its place; its rock layers are mixed with the constants 0.8 and 0.5, and the second
//     grass layer with Grass_mask / 2.
//
// FRAGMENT INPUTS. What the rasterizer interpolates per fragment (perspective-correct), under
// the names each shader gives them:
//   worldPosition  lab4 evaluationIn.worldPosition, pn v3PositionOut
//   normal         thesis gNormal, cosc422 faceNormal, lab4 normal, pn v3NormalOut
//   texCoord       thesis gTextureCoordinate, cosc422/lab4 texCoord, pn v2UVOut
//   texCoord_dx/dy dFdx(texCoord), dFdy(texCoord): per window pixel in x and y. On llvmpipe
//                  these are per-2x2-quad differences of the visible primitive's interpolated
//                  texCoord (helper pixels evaluate its plane outside the triangle); for a
//                  texCoord affine in screen space both equal the analytic derivative. Zero
//                  derivatives give lod -inf, i.e. the magnification filter on level 0.
//   depth          gl_FragCoord.z, window depth in [0, 1]
// Lab 4's "height" is worldPosition.y, as its shader reads it; no shader reads an eye-space
// position. fragment_needs() says which inputs a model reads, so that a renderer interpolates
// only those.
//
// PARAMETERS. Each model's uniforms are a plain struct named after the shader, members named
// as the uniforms, defaults equal to the GLSL initializers where the shader has them (the
// differential test leaves those uniforms unset in GL and checks the result). The thesis's
// uniforms have no initializers and the thesis does not publish its values; the defaults
// below are tessref's, chosen so that a flat terrain reads about 0.9 of its texture.
// ShadingModel gathers the kind, every model's parameters and the textures, so that the scene
// loader ([shading] table) can fill it without knowing the shader code.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <glm/glm.hpp>

#include "tessref/parallax.h"
#include "tessref/texture.h"

namespace tessref {

enum class ShadingKind : std::uint8_t { flat, depth, thesis_single, thesis_multi, lab4, cosc422, pn, geomip_lightmap, pom };

// "flat", "depth", "thesis_single", "thesis_multi", "lab4", "cosc422", "pn", "geomip_lightmap",
// "pom".
const char* to_string(ShadingKind kind);
// The inverse of to_string; nullopt for an unknown name.
std::optional<ShadingKind> shading_kind_from_string(std::string_view name);

// ---- what one fragment receives ----------------------------------------------------------

struct FragmentInputs {
    glm::vec3 worldPosition{0.0f};
    glm::vec3 normal{0.0f, 0.0f, 1.0f};
    glm::vec2 texCoord{0.0f};
    glm::vec2 texCoord_dx{0.0f};  // dFdx(texCoord)
    glm::vec2 texCoord_dy{0.0f};  // dFdy(texCoord)
    float depth = 0.0f;           // gl_FragCoord.z
    // The uv derivatives of the fragment's triangle (parallax.h, TANGENT FRAME): what pom.frag
    // derives from dFdx/dFdy of its position and uv. Zero when the surface has no uv.
    glm::vec3 dPdu{0.0f};
    glm::vec3 dPdv{0.0f};
};

// Which FragmentInputs members a model reads.
struct FragmentNeeds {
    bool worldPosition = false;
    bool normal = false;
    bool texCoord = false;
    bool texCoord_derivatives = false;  // only models that sample a texture
    bool depth = false;
    bool uv_derivatives = false;  // dPdu, dPdv (pom)
};
FragmentNeeds fragment_needs(ShadingKind kind);

// ---- uniforms ----------------------------------------------------------------------------

// Listing 3's uniforms (both thesis shaders). tessref defaults (see PARAMETERS above).
struct ThesisLight {
    glm::vec3 lightPosition{0.25f, 0.25f, 1.0f};  // used as an unnormalized direction (quirk)
    glm::vec3 diffuseMaterial{0.75f};
    glm::vec3 ambientMaterial{0.1f};  // single-texture shader only (multi uses AmbientOcc)
    glm::vec3 specularMaterial{0.1f};
    float shininess = 50.0f;
};

// thesis_terrain.frag's rotationMatrix ("Rotates texture coordinates by 90 degrees"), applied
// to the row vector vec4(st, 1, 1). The default turns st by 90 degrees about the texture's
// centre: (s, t) -> (t, 1 - s). A turn about the origin, (t, -s), differs from it by one
// whole tile, which repeat-tiled detail textures would not show but clamp-to-edge sampling
// (tessref's only wrap mode) would: the centre keeps the rotated coordinate inside [0, 1].
glm::mat4 thesis_default_rotation_matrix();

// lab4_terrain.frag's uniforms; defaults are the shader's initializers.
struct Lab4Shading {
    glm::vec3 cameraPosition{0.0f};  // no initializer in GLSL: the scene's camera eye
    glm::vec3 lightDirection{0.3f, 1.0f, 0.2f};
    glm::vec3 sandColour{0.76f, 0.70f, 0.50f};
    glm::vec3 rockColour{0.45f, 0.40f, 0.36f};
    float sandHeight = 50.0f;
    float blendWidth = 10.0f;
};

// cosc422_terrain.frag's uniforms; defaults are the shader's initializers.
struct Cosc422Shading {
    glm::vec3 lightDirection{0.0f, 1.0f, 0.0f};
    float ambient = 0.2f;
};

// pn_triangles.frag's uniforms; defaults are the shader's initializers.
struct PnShading {
    glm::vec3 v3CameraPosition{0.0f};  // no initializer in GLSL: the scene's camera eye
    glm::vec3 v3LightDirection{0.4f, 0.8f, 0.45f};
    glm::vec3 v3DiffuseColour{0.8f, 0.8f, 0.85f};
    float fShininess = 32.0f;
};

// pom.frag's uniforms (the PN-triangles tutorial's normal mapping, parallax occlusion
// mapping and self-shadowing; parallax.h); defaults are the shader's initializers. The
// light is pn_triangles.frag's. Its three textures are sampled with GL_REPEAT (GL's default
// wrap mode; the scene loader sets it), so that fUvRepeat tiles them.
struct PomShading {
    glm::vec3 v3CameraPosition{0.0f};  // no initializer in GLSL: the scene's camera eye
    glm::vec3 v3LightDirection{0.4f, 0.8f, 0.45f};
    glm::vec3 v3DiffuseColour{1.0f};   // times the diffuse texture
    float fShininess = 32.0f;
    ParallaxParams parallax{};         // iParallaxMode, fBumpScale, fMinLayers, fMaxLayers, fShadowLayers
    bool bSelfShadow = true;
    float fUvRepeat = 1.0f;            // v2UV = texCoord * fUvRepeat: tiles across the surface's uv
};

// The "no shading" modes.
struct FlatShading {
    glm::vec4 colour{1.0f};  // every fragment (raster.h's RasterSettings::colour default)
};
enum class DepthMapping : std::uint8_t {
    window,  // grey = gl_FragCoord.z, what a depth buffer holds (near 1 for most of a
             // perspective view)
    linear,  // grey = (z_eye - near) / (far - near), z_eye the eye distance along the view
             // axis recovered from gl_FragCoord.z for a GL perspective projection with depth
             // range [0, 1]: near -> 0, far -> 1
};
struct DepthShading {
    DepthMapping mapping = DepthMapping::linear;
    float near_plane = 1.0f;      // the camera's near and far (scene.h SceneCamera)
    float far_plane = 10000.0f;
};

// The geomorphing article's terrain shading ("Materials"): a light map computed from the
// height map (geomipmap.h, LIGHT MAP) instead of vertex normals, which would pop as the levels
// change; material textures repeated over the terrain, each modulated by the light map and
// alpha-blended over the passes before it by its alpha map; then an optional cloud-shadow
// texture, repeated and scrolled, multiplied in. The article draws one pass per material into
// the framebuffer; this is the single-pass equivalent (one fragment, the blend in float, no
// 8-bit rounding between passes). GLSL twin: geomip_terrain.frag (at most 4 materials).
struct GeomipMaterial {
    std::shared_ptr<const Texture> texture;  // the material, sampled with GL_REPEAT
    float repeat = 1.0f;                     // tiles across the terrain (the texture matrix's scale)
    std::shared_ptr<const Texture> alpha;    // its alpha map (red channel); null for the base pass
};
struct GeomipLightmapShading {
    std::shared_ptr<const Texture> lightMap;  // one texel per height sample (red channel)
    // uv (sample / (size - 1)) -> light and alpha map coordinates with texel centres on the
    // samples: st = uv * (size - 1) / size + 0.5 / size.
    glm::vec2 lightMapScale{1.0f};
    glm::vec2 lightMapOffset{0.0f};
    std::vector<GeomipMaterial> materials;    // at least one; the first is the base pass
    std::shared_ptr<const Texture> clouds;    // null: no cloud pass; sampled with GL_REPEAT
    float cloudRepeat = 1.0f;
    glm::vec2 cloudOffset{0.0f};              // fract(velocity * time): the scrolled translation
};

// ---- textures ----------------------------------------------------------------------------

// Every sampler of the shaders, by its GLSL name (binding in comments). Null: none bound.
struct ShadingTextures {
    // thesis_terrain.frag / thesis_terrain_single.frag
    std::shared_ptr<const Texture> diffuse;               // binding 4
    std::shared_ptr<const Texture> canyon_rock01;         // binding 5
    std::shared_ptr<const Texture> canyon_rock02;         // binding 6
    std::shared_ptr<const Texture> dry_grass09;           // binding 7
    std::shared_ptr<const Texture> dry_grass12;           // binding 8
    std::shared_ptr<const Texture> romanian_sand05;       // binding 9
    std::shared_ptr<const Texture> VertRock_0_90_mask;    // binding 10
    std::shared_ptr<const Texture> VertDetail_0_90_mask;  // binding 11
    std::shared_ptr<const Texture> Grass_mask;            // binding 12
    std::shared_ptr<const Texture> Flow_mask;             // binding 13
    std::shared_ptr<const Texture> AmbientOcc;            // binding 14
    // cosc422_terrain.frag: the terrain's height map used as a grey texture (binding 0). A
    // scene holding a shared_ptr<const HeightField> hf can pass
    // std::shared_ptr<const Texture>(hf, &hf->texture).
    std::shared_ptr<const Texture> heightMap;
    // pom.frag: the tutorial's diffuse, normal and bump (height) maps (bindings 4, 5, 6)
    std::shared_ptr<const Texture> s2DiffuseTexture;
    std::shared_ptr<const Texture> s2NormalTexture;
    std::shared_ptr<const Texture> s2BumpTexture;
};

// The samplers a model's shader declares, in binding order ("diffuse", ..., "AmbientOcc";
// "heightMap"); empty for flat, depth, lab4 and pn.
std::span<const std::string_view> sampler_names(ShadingKind kind);
// The slot of a sampler by its GLSL name (for a scene loader's textures table); null for a
// name that is no sampler of any model.
std::shared_ptr<const Texture>* sampler_slot(ShadingTextures& textures, std::string_view name);
const std::shared_ptr<const Texture>* sampler_slot(const ShadingTextures& textures,
                                                   std::string_view name);

// ---- the model ---------------------------------------------------------------------------

struct ShadingModel {
    ShadingKind kind = ShadingKind::flat;
    FlatShading flat{};
    DepthShading depth{};
    ThesisLight thesis{};                                          // thesis_single, thesis_multi
    glm::mat4 rotationMatrix = thesis_default_rotation_matrix();   // thesis_multi
    Lab4Shading lab4{};
    Cosc422Shading cosc422{};
    PnShading pn{};
    GeomipLightmapShading geomip{};
    PomShading pom{};
    ShadingTextures textures{};
};

// A scene's fragment stage: its [shading] table (data/scenes/README.md), read with the scene
// (Scene::shading). The default is what a scene without [shading] gets: depth shading with
// the linear mapping.
struct RenderShading {
    ShadingModel model{.kind = ShadingKind::depth};
    glm::vec4 background{0.0f};                          // glClearColor
    glm::vec4 wireframe_colour{0.0f, 0.0f, 0.0f, 1.0f};  // the lines of --overlay-wireframe
};

// The samplers of model.kind that have no texture (they would read (0, 0, 0, 1)); a scene
// loader may refuse such a model with an error naming them.
std::vector<std::string_view> missing_textures(const ShadingModel& model);

// The colour of one fragment: the model's shader run on it.
glm::vec4 shade(const ShadingModel& model, const FragmentInputs& fragment);
// The colours of several fragments (a quad's), out[k] = shade(model, fragments[k]) bit for
// bit: the single-texture thesis shader takes its magnified fragments' texture lookups
// together (Texture::reads_level0_only); every other model runs fragment by fragment. out is
// as long as fragments (else tessref::Error).
void shade(const ShadingModel& model, std::span<const FragmentInputs> fragments, std::span<glm::vec4> out);

// ---- the pieces (each mirrors the shader lines named in src/shading/) ---------------------

// The level of detail texture() picks in a fragment shader for a texture of level-0 size
// w x h, as llvmpipe (Mesa 22.3) computes it:
//   rho_x^2 = (w*dPdx.s)^2 + (h*dPdx.t)^2,  rho_y^2 = (w*dPdy.s)^2 + (h*dPdy.t)^2
//   lambda  = 0.5 * fast_log2(max(rho_x^2, rho_y^2))
// in float. GL 4.5 (8.7)-(8.8) asks for log2(rho) = 0.5 * log2(rho^2); llvmpipe's
// fast_log2 is piecewise linear between powers of two (exact at them), so its lambda equals
// GL's at integer and half-integer lods and is up to 0.043 smaller in between (measured with
// textureQueryLod and mip levels of distinct constant values on llvmpipe 15.0.6 / Mesa
// 22.3.6; the differential test depends on it). No lod bias, min/max lod at their defaults;
// lambda <= 0 means magnification (textureLod clamps it to level 0).
float fragment_lod(const Texture& sampler, glm::vec2 dPdx, glm::vec2 dPdy);
// llvmpipe's lp_build_fast_log2(x) = floor(log2 x) + (x / 2^floor(log2 x) - 1), computed from
// the float's bits (exponent field - 128, plus the mantissa as a number in [1, 2)): exact at
// powers of two, below log2 in between. 0 gives -127, +inf 128, a quiet NaN 128.5 (so a NaN
// derivative samples the last level), as on llvmpipe.
float fast_log2(float x);

// GLSL textureGrad(sampler, P, dPdx, dPdy) = texture(sampler, P) in a fragment shader with
// dFdx(P) = dPdx, dFdy(P) = dPdy. A null or empty sampler reads (0, 0, 0, 1).
glm::vec4 textureGrad(const Texture* sampler, glm::vec2 P, glm::vec2 dPdx, glm::vec2 dPdy);

// Listing 3 (thesis section 4.9): light = ambient + df * diffuseMaterial + sf *
// specularMaterial with df = abs(dot(gNormal, lightPosition)) and sf = pow(abs(dot(gNormal,
// normalize(lightPosition + (0, 0, 1)))), shininess). `ambient` is ambientMaterial in the
// single-texture shader and texture(AmbientOcc, st).rgb in the multi-texture one.
glm::vec3 thesis_light(glm::vec3 gNormal, glm::vec3 ambient, const ThesisLight& uniforms);

glm::vec4 thesis_single_texture(const FragmentInputs& fragment, const ThesisLight& uniforms,
                                const Texture* diffuse);
glm::vec4 thesis_multi_texture(const FragmentInputs& fragment, const ThesisLight& uniforms,
                               const glm::mat4& rotationMatrix, const ShadingTextures& textures);

// Lab 4's material weights: heightWeight = smoothstep(sandHeight - blendWidth, sandHeight +
// blendWidth, worldPosition.y), slopeWeight = 1 - smoothstep(0.6, 0.8, normalize(n).y),
// rock = max(heightWeight, slopeWeight) (the slope overrides the height), sand = 1 - rock:
// albedo = mix(sandColour, rockColour, rock) = sand * sandColour + rock * rockColour.
struct Lab4Weights {
    float heightWeight = 0.0f;
    float slopeWeight = 0.0f;
    float rock = 0.0f;
    float sand = 1.0f;
};
Lab4Weights lab4_weights(glm::vec3 worldPosition, glm::vec3 normal, const Lab4Shading& uniforms);
glm::vec4 lab4_terrain(const FragmentInputs& fragment, const Lab4Shading& uniforms);

glm::vec4 cosc422_terrain(const FragmentInputs& fragment, const Cosc422Shading& uniforms,
                          const Texture* heightMap);
glm::vec4 pn_triangles(const FragmentInputs& fragment, const PnShading& uniforms);

glm::vec4 geomip_lightmap(const FragmentInputs& fragment, const GeomipLightmapShading& uniforms);

// Normal mapping with the tangent frame of fragment.dPdu/dPdv, the parallax of
// uniforms.parallax.mode and, with bSelfShadow, the self-shadow trace (parallax.h); the
// diffuse texture at the shifted uv times v3DiffuseColour, lit as pn_triangles.
glm::vec4 pom_shading(const FragmentInputs& fragment, const PomShading& uniforms, const ShadingTextures& textures);

glm::vec4 flat_colour(const FlatShading& uniforms);
glm::vec4 depth_colour(const FragmentInputs& fragment, const DepthShading& uniforms);

}  // namespace tessref
