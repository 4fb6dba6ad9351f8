#include "penumbra/shading.h"

#include <algorithm>
#include <cmath>

#include "penumbra/material_inputs.h"
#include "penumbra/shape.h"

namespace penumbra {
namespace {

constexpr float kDegreesToRadians = 3.14159265358979f / 180.0f;

Vec2f operator+(Vec2f a, Vec2f b) {
  return {a.x + b.x, a.y + b.y};
}
Vec2f operator-(Vec2f a, Vec2f b) {
  return {a.x - b.x, a.y - b.y};
}
Vec2f operator*(Vec2f a, float s) {
  return {a.x * s, a.y * s};
}

/// A texture reader's coordinates at a point: st, and how st changes across the primitive.
struct CoordinatesAt {
  TextureFootprint footprint;
  Vec2f edge1{0, 0}, edge2{0, 0};  // st(corner 1) - st(corner 0), st(corner 2) - st(corner 0)
};

/// The barycentric step (a, b) with a·e1 + b·e2 closest to `dp` (least squares in the
/// triangle's plane); zero for degenerate triangles.
Vec2f barycentricStep(const Vec3f& e1, const Vec3f& e2, const Vec3f& dp) {
  const float g11 = dot(e1, e1), g12 = dot(e1, e2), g22 = dot(e2, e2);
  const float determinant = g11 * g22 - g12 * g12;
  if (!(determinant > 0)) return {0, 0};
  const float p1 = dot(dp, e1), p2 = dot(dp, e2);
  return {(g22 * p1 - g12 * p2) / determinant, (g11 * p2 - g12 * p1) / determinant};
}

/// The copy's own value of primvar `name`, if it has one (NaN marks copies without one).
const float* instanceValue(const SurfacePoint& point, const PrimvarName& name, int* width) {
  const Primvar* primvar =
      point.instancePrimvars ? findPrimvar(*point.instancePrimvars, name) : nullptr;
  if (!primvar) return nullptr;
  const float* value = &primvar->values[point.instance * size_t(primvar->width)];
  if (std::isnan(value[0])) return nullptr;
  *width = primvar->width;
  return value;
}

CoordinatesAt coordinatesAt(const TextureCoordinates& coordinates, const SurfacePoint& point) {
  CoordinatesAt result;
  if (coordinates.primvar.empty()) {
    result.footprint.st = coordinates.apply(coordinates.fallback);
    return result;
  }
  int width = 0;
  if (const float* value = instanceValue(point, coordinates.primvar, &width)) {
    // One value per copy: constant over the surface.
    result.footprint.st =
        coordinates.apply(width >= 2 ? Vec2f{value[0], value[1]} : coordinates.fallback);
    return result;
  }
  Vec2f st[3];
  if (!point.shape->cornerCoordinates(point, coordinates.primvar, st)) {
    result.footprint.st = coordinates.apply(coordinates.fallback);
    return result;
  }
  const Vec2f at = st[0] * (1 - point.u - point.v) + st[1] * point.u + st[2] * point.v;
  const Vec3f e1 = point.corners[1] - point.corners[0];
  const Vec3f e2 = point.corners[2] - point.corners[0];
  result.edge1 = coordinates.applyLinear(st[1] - st[0]);
  result.edge2 = coordinates.applyLinear(st[2] - st[0]);
  const auto stepOf = [&](const Vec3f& dp) {
    const Vec2f step = barycentricStep(e1, e2, dp);
    return result.edge1 * step.x + result.edge2 * step.y;
  };
  result.footprint = {coordinates.apply(at), stepOf(point.dpdx), stepOf(point.dpdy)};
  return result;
}

/// A UsdUVTexture's four output channels at a point: the texel × scale + bias, or the fallback
/// where there is no texel (missing file or UDIM tile), which scale and bias do not touch.
std::array<float, 4> sampleTexture(const TextureReader& reader, const TextureSystem& textures,
                                   const CoordinatesAt& at) {
  float rgba[4];
  if (reader.texture == TextureSystem::kInvalid ||
      !textures.lookup(reader.texture, reader.wrapS, reader.wrapT, at.footprint, rgba))
    return reader.fallback;
  std::array<float, 4> result;
  for (int c = 0; c < 4; ++c)
    result[size_t(c)] = rgba[c] * reader.scale[size_t(c)] + reader.bias[size_t(c)];
  return result;
}

/// A primvar reader's value: the primvar at the point, or the reader's fallback.
void readPrimvar(const InputConnection& connection, const SurfacePoint& point, float value[4],
                 int* width) {
  if (primvarAt(point, connection.primvar, value, width)) return;
  std::copy(connection.fallback.begin(), connection.fallback.end(), value);
  *width = 3;
}

/// Writes an input's value (three floats for vector inputs, one for the others) into the
/// member the material input table names.
void assign(MaterialParams& params, MaterialInput input, const float* value) {
  const MaterialParamMember& member = materialInputInfo(input).member;
  if (const auto color = std::get_if<Vec3f MaterialParams::*>(&member))
    params.*(*color) = Vec3f{value[0], value[1], value[2]};
  else if (const auto number = std::get_if<float MaterialParams::*>(&member))
    params.*(*number) = value[0];
  // Normal has no member: it bends the shading normal instead.
}

/// The value of `program` (ExpressionProgram::problem() empty) at `point`, and, in `*coordinates`
/// and `*hasCoordinates`, the coordinates of its first texture (normal maps take their tangent
/// frame from them). Values live on the stack: nothing is allocated.
std::array<float, 4> evaluateProgram(const Material& material, const ExpressionProgram& program,
                                     const TextureSystem& textures, const SurfacePoint& point,
                                     CoordinatesAt* coordinates, bool* hasCoordinates) {
  std::array<std::array<float, 4>, ExpressionProgram::kMaxNodes> values;
  *hasCoordinates = false;
  for (size_t i = 0; i < program.nodes.size(); ++i) {
    const ExpressionNode& node = program.nodes[i];
    const std::array<float, 4>& a = values[node.operands[0]];
    const std::array<float, 4>& b = values[node.operands[1]];
    const std::array<float, 4>& c = values[node.operands[2]];
    std::array<float, 4>& out = values[i];
    const auto componentWise = [&](auto f) {
      for (size_t k = 0; k < 4; ++k) out[k] = f(a[k], b[k], c[k]);
    };
    switch (node.op) {
      case ExpressionOp::Constant:
        out = node.value;
        break;
      case ExpressionOp::Texture: {
        const TextureReader& reader = material.textures[size_t(node.texture)];
        const CoordinatesAt at = coordinatesAt(reader.coordinates, point);
        out = sampleTexture(reader, textures, at);
        if (!*hasCoordinates) *coordinates = at, *hasCoordinates = true;
        break;
      }
      case ExpressionOp::Primvar: {
        float value[4] = {0, 0, 0, 0};
        int width = 0;
        if (primvarAt(point, node.primvar, value, &width)) {
          for (int k = 0; k < 4; ++k) out[size_t(k)] = k < width ? value[k] : 0.0f;
        } else {
          out = node.value;
        }
        break;
      }
      case ExpressionOp::Swizzle:
        for (size_t k = 0; k < 4; ++k) out[k] = a[node.channels[k]];
        break;
      case ExpressionOp::Concatenate:
        for (size_t k = 0; k < 4; ++k)
          out[k] = k < node.channels[0] ? a[k] : b[k - node.channels[0]];
        break;
      case ExpressionOp::Add:
        componentWise([](float x, float y, float) { return x + y; });
        break;
      case ExpressionOp::Subtract:
        componentWise([](float x, float y, float) { return x - y; });
        break;
      case ExpressionOp::Multiply:
        componentWise([](float x, float y, float) { return x * y; });
        break;
      case ExpressionOp::Divide:
        componentWise([](float x, float y, float) { return y != 0 ? x / y : 0.0f; });
        break;
      case ExpressionOp::Mix:
        componentWise([](float fg, float bg, float amount) { return bg + (fg - bg) * amount; });
        break;
      case ExpressionOp::Clamp:
        componentWise(
            [](float x, float low, float high) { return std::min(std::max(x, low), high); });
        break;
    }
  }
  return values[program.nodes.size() - 1];
}

/// Evaluates connections of `material` (those `wanted` accepts) at `point`, calling
/// `use(connection, value, coordinates)` with the connection's value (three floats, broadcast
/// from one channel where needed) and, for texture connections, the reader's coordinates.
template <typename Wanted, typename Use>
void evaluateConnections(const Material& material, const TextureSystem& textures,
                         const SurfacePoint& point, Wanted wanted, Use use) {
  int cachedReader = -1;  // consecutive connections often read one texture's channels
  CoordinatesAt coordinates;
  std::array<float, 4> texel{};
  for (const InputConnection& connection : material.connections) {
    if (!wanted(connection)) continue;
    float value[4] = {0, 0, 0, 0};
    int width = connection.channelCount;
    if (connection.program >= 0) {
      CoordinatesAt programCoordinates;
      bool hasCoordinates = false;
      const std::array<float, 4> result =
          evaluateProgram(material, material.programs[size_t(connection.program)], textures, point,
                          &programCoordinates, &hasCoordinates);
      std::copy_n(result.begin(), width, value);
      if (width == 1) value[1] = value[2] = value[0];
      use(connection, value, hasCoordinates ? &programCoordinates : nullptr);
      continue;
    }
    if (connection.texture >= 0) {
      if (connection.texture != cachedReader) {
        const TextureReader& reader = material.textures[size_t(connection.texture)];
        coordinates = coordinatesAt(reader.coordinates, point);
        texel = sampleTexture(reader, textures, coordinates);
        cachedReader = connection.texture;
      }
      std::copy_n(texel.begin() + connection.firstChannel, width, value);
    } else {
      readPrimvar(connection, point, value, &width);
    }
    if (width == 1) value[1] = value[2] = value[0];
    use(connection, value, connection.texture >= 0 ? &coordinates : nullptr);
  }
}

/// ∂P/∂s and ∂P/∂t of the triangle at `point` for texture coordinates changing by d1 and d2
/// along its edges from corner 0 to corners 1 and 2; false where they give no frame.
bool textureTangents(Vec2f d1, Vec2f d2, const SurfacePoint& point, Vec3f* dpds, Vec3f* dpdt) {
  const float determinant = d1.x * d2.y - d1.y * d2.x;
  if (std::abs(determinant) < 1e-12f) return false;
  const Vec3f e1 = point.corners[1] - point.corners[0];
  const Vec3f e2 = point.corners[2] - point.corners[0];
  *dpds = (e1 * d2.y - e2 * d1.y) / determinant;
  *dpdt = (e2 * d1.x - e1 * d2.x) / determinant;
  return true;
}

/// The shading normal bent by a tangent-space normal `mapped` (x along +s, y along +t, z along
/// the normal), or the normal unchanged where the texture coordinates give no tangent frame.
Vec3f applyNormalMap(const Vec3f& normal, const Vec3f& mapped, const CoordinatesAt* coordinates,
                     const SurfacePoint& point) {
  Vec3f dpds, dpdt;
  if (!coordinates || !textureTangents(coordinates->edge1, coordinates->edge2, point, &dpds, &dpdt))
    return normal;
  const Vec3f tangent = dpds - normal * dot(normal, dpds);
  if (!(length(tangent) > 0)) return normal;
  const Vec3f s = normalize(tangent);
  Vec3f t = cross(normal, s);
  if (dot(t, dpdt) < 0) t = -t;  // mirrored texture coordinates
  const Vec3f bent = s * mapped.x + t * mapped.y + normal * mapped.z;
  // A bent normal facing away from the geometric one would shade the surface inside out.
  if (!(length(bent) > 0) || dot(bent, point.normal) <= 0) return normal;
  return normalize(bent);
}

}  // namespace

bool primvarAt(const SurfacePoint& point, const PrimvarName& name, float value[4], int* width) {
  if (const float* own = instanceValue(point, name, width)) {
    std::copy(own, own + *width, value);
    return true;
  }
  return point.shape->primvarAt(point, name, value, width);
}

MaterialParams fallbackSurface() {
  MaterialParams params;
  params.diffuseColor = Vec3f(0.5f);
  params.roughness = 1;
  params.useSpecularWorkflow = true;
  params.specularColor = Vec3f(0.0f);
  params.transmissionRoughness = 0;  // displayOpacity sees clearly through, as blending does
  return params;
}

Vec2f TextureCoordinates::applyLinear(Vec2f dst) const {
  const float angle = rotation * kDegreesToRadians;
  const float c = std::cos(angle), s = std::sin(angle);
  const Vec2f scaled{dst.x * scale.x, dst.y * scale.y};
  return {c * scaled.x - s * scaled.y, s * scaled.x + c * scaled.y};
}

Vec2f TextureCoordinates::apply(Vec2f st) const {
  return applyLinear(st) + translation;
}

bool Material::opacityVaries() const {
  return std::any_of(connections.begin(), connections.end(),
                     [](const InputConnection& c) { return c.input == MaterialInput::Opacity; });
}

std::string ExpressionProgram::problem(size_t textureCount) const {
  if (nodes.empty() || nodes.size() > kMaxNodes)
    return "a program has 1 to " + std::to_string(kMaxNodes) + " nodes, not " +
           std::to_string(nodes.size());
  for (size_t i = 0; i < nodes.size(); ++i) {
    const ExpressionNode& node = nodes[i];
    const std::string where = "program node " + std::to_string(i) + ": ";
    for (const uint8_t operand : node.operands)
      if (i > 0 ? operand >= i : operand != 0) return where + "an operand is not an earlier node";
    if (i == 0 && node.op != ExpressionOp::Constant && node.op != ExpressionOp::Texture &&
        node.op != ExpressionOp::Primvar)
      return where + "the first node must be a constant, a texture or a primvar";
    for (const uint8_t channel : node.channels)
      if (channel > 3) return where + "channels are 0 to 3";
    if (node.op == ExpressionOp::Concatenate && (node.channels[0] < 1 || node.channels[0] > 3))
      return where + "a concatenation takes 1 to 3 channels of its first operand";
    for (const float v : node.value)
      if (!std::isfinite(v)) return where + "constants and fallbacks must be finite";
    if (node.op == ExpressionOp::Texture &&
        (node.texture < 0 || size_t(node.texture) >= textureCount))
      return where + "no such texture";
  }
  return {};
}

bool Material::mayBeAnisotropic() const {
  return constants.anisotropy > 0 || constants.clearcoatAnisotropy > 0 ||
         std::any_of(connections.begin(), connections.end(), [](const InputConnection& c) {
           return c.input == MaterialInput::Anisotropy ||
                  c.input == MaterialInput::ClearcoatAnisotropy;
         });
}

Vec3f surfaceTangent(const SurfacePoint& point, const Transform& objectToWorld) {
  static const PrimvarName tangentName("tangent");  // looked up on every anisotropic hit
  float value[4];
  int width = 0;
  if (primvarAt(point, tangentName, value, &width) && width >= 3)
    return objectToWorld.applyToVector({value[0], value[1], value[2]});
  static const TextureCoordinates st = [] {
    TextureCoordinates coordinates;
    coordinates.primvar = "st";
    return coordinates;
  }();
  const CoordinatesAt coordinates = coordinatesAt(st, point);
  Vec3f dpds, dpdt;
  return textureTangents(coordinates.edge1, coordinates.edge2, point, &dpds, &dpdt) ? dpds
                                                                                    : Vec3f(0.0f);
}

void footprintOnSurface(const Vec3f& direction, const Vec3f& normal, float radius, Vec3f* dpdx,
                        Vec3f* dpdy) {
  const float cosine = dot(direction, normal);
  const Vec3f along = direction - normal * cosine;
  const float alongLength = length(along);
  if (alongLength < 1e-6f) {
    const Frame frame(normal);
    *dpdx = frame.s * radius;
    *dpdy = frame.t * radius;
    return;
  }
  const Vec3f s = along / alongLength;
  *dpdx = s * (radius / std::max(std::abs(cosine), 0.05f));
  *dpdy = cross(normal, s) * radius;
}

MaterialParams evaluateMaterial(const Material& material, const TextureSystem& textures,
                                const SurfacePoint& point, Vec3f* shadingNormal) {
  MaterialParams params = material.constants;
  evaluateConnections(
      material, textures, point, [](const InputConnection&) { return true; },
      [&](const InputConnection& connection, const float* value, const CoordinatesAt* coordinates) {
        if (connection.input == MaterialInput::Normal)
          *shadingNormal =
              applyNormalMap(*shadingNormal, {value[0], value[1], value[2]}, coordinates, point);
        else
          assign(params, connection.input, value);
      });
  return params;
}

float evaluateOpacity(const Material& material, const TextureSystem& textures,
                      const SurfacePoint& point) {
  float opacity = material.constants.opacity;
  evaluateConnections(
      material, textures, point,
      [](const InputConnection& connection) { return connection.input == MaterialInput::Opacity; },
      [&](const InputConnection&, const float* value, const CoordinatesAt*) {
        opacity = value[0];
      });
  return opacity;
}

}  // namespace penumbra
