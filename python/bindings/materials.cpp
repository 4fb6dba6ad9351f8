// Material sprims: set_material's dict schemas (docs/core-api.md) — UsdPreviewSurface inputs,
// constant or connected to a UsdUVTexture, a primvar reader or a pattern program.
#include <map>
#include <stdexcept>
#include <string>

#include "bindings.h"
#include "conversions.h"

namespace penumbra::bindings {
namespace {

using plugin::InputSource;
using plugin::Material;
using plugin::ProgramNode;
using plugin::RenderDelegate;
using plugin::TextureNode;

/// A UsdUVTexture's description (docs/core-api.md, set_material).
TextureNode toTextureNode(const std::string& where, const py::dict& dict) {
  TextureNode node;
  readDict(
      where, dict,
      {"file", "wrapS", "wrapT", "sourceColorSpace", "colorSpace", "scale", "bias", "fallback",
       "st", "transform"},
      [&](const std::string& key, const py::handle& value) {
        const std::string at = where + "." + key;
        if (key == "file") node.file = value.cast<std::string>();
        if (key == "wrapS") node.reader.wrapS = plugin::parseTextureWrap(value.cast<std::string>());
        if (key == "wrapT") node.reader.wrapT = plugin::parseTextureWrap(value.cast<std::string>());
        if (key == "sourceColorSpace")
          node.colorSpace.source = plugin::parseSourceColorSpace(value.cast<std::string>());
        if (key == "colorSpace") node.colorSpace.name = value.cast<std::string>();
        if (key == "scale") node.reader.scale = toFloats<4>(at, value);
        if (key == "bias") node.reader.bias = toFloats<4>(at, value);
        if (key == "fallback") node.reader.fallback = toFloats<4>(at, value);
        if (key == "st")
          readDict(at, value.cast<py::dict>(), {"primvar", "fallback"},
                   [&](const std::string& stKey, const py::handle& stValue) {
                     if (stKey == "primvar")
                       node.reader.coordinates.primvar = PrimvarName(stValue.cast<std::string>());
                     else {
                       const auto st = toFloats<2>(at + ".fallback", stValue);
                       node.reader.coordinates.fallback = {st[0], st[1]};
                     }
                   });
        if (key == "transform")
          readDict(at, value.cast<py::dict>(), {"scale", "rotation", "translation"},
                   [&](const std::string& tKey, const py::handle& tValue) {
                     if (tKey == "rotation") {
                       node.reader.coordinates.rotation = tValue.cast<float>();
                       return;
                     }
                     const auto pair = toFloats<2>(at + "." + tKey, tValue);
                     (tKey == "scale" ? node.reader.coordinates.scale
                                      : node.reader.coordinates.translation) = {pair[0], pair[1]};
                   });
      });
  if (node.file.empty()) throw std::invalid_argument(where + ": a texture needs a 'file'");
  return node;
}

/// Up to 4 small non-negative integers (operand indices, channels), zero-padded.
std::array<uint8_t, 4> toIndices(const std::string& where, const py::handle& value, size_t most) {
  const auto items = value.cast<std::vector<int>>();
  if (items.size() > most)
    throw std::invalid_argument(where + " takes at most " + std::to_string(most) + " entries");
  std::array<uint8_t, 4> result{0, 0, 0, 0};
  for (size_t i = 0; i < items.size(); ++i) {
    if (items[i] < 0 || items[i] > 255) throw std::invalid_argument(where + " is out of range");
    result[i] = uint8_t(items[i]);
  }
  return result;
}

/// A pattern program node (docs/core-api.md, set_material): {"op": name, "in": [operands],
/// "channels": [...], "split": n, "value": (4 floats), "texture": {...}, "primvar": name,
/// "fallback": (4 floats)}.
ProgramNode toProgramNode(const std::string& where, const py::dict& dict) {
  static const std::map<std::string, ExpressionOp> ops = {
      {"constant", ExpressionOp::Constant},
      {"texture", ExpressionOp::Texture},
      {"primvar", ExpressionOp::Primvar},
      {"swizzle", ExpressionOp::Swizzle},
      {"concatenate", ExpressionOp::Concatenate},
      {"add", ExpressionOp::Add},
      {"subtract", ExpressionOp::Subtract},
      {"multiply", ExpressionOp::Multiply},
      {"divide", ExpressionOp::Divide},
      {"mix", ExpressionOp::Mix},
      {"clamp", ExpressionOp::Clamp}};
  ProgramNode node;
  bool hasOp = false;
  readDict(where, dict,
           {"op", "in", "channels", "split", "value", "texture", "primvar", "fallback"},
           [&](const std::string& key, const py::handle& value) {
             const std::string at = where + "." + key;
             if (key == "op") {
               const auto op = ops.find(value.cast<std::string>());
               if (op == ops.end())
                 throw std::invalid_argument("unknown program operation '" +
                                             value.cast<std::string>() + "'");
               node.node.op = op->second;
               hasOp = true;
             }
             if (key == "in") {
               const std::array<uint8_t, 4> operands = toIndices(at, value, 3);
               std::copy_n(operands.begin(), 3, node.node.operands.begin());
             }
             if (key == "channels") node.node.channels = toIndices(at, value, 4);
             if (key == "split") node.node.channels[0] = toIndices(at, py::make_tuple(value), 1)[0];
             if (key == "value" || key == "fallback") node.node.value = toFloats<4>(at, value);
             if (key == "texture") node.texture = toTextureNode(at, value.cast<py::dict>());
             if (key == "primvar") node.node.primvar = PrimvarName(value.cast<std::string>());
           });
  if (!hasOp) throw std::invalid_argument(where + ": a program node needs an 'op'");
  return node;
}

/// A connected input's source: {"texture": {...}, "output": "rgb"},
/// {"primvar": name, "fallback": value} or {"program": [nodes]}.
InputSource toInputSource(const std::string& where, const py::dict& dict) {
  InputSource source;
  readDict(where, dict, {"texture", "output", "primvar", "fallback", "program"},
           [&](const std::string& key, const py::handle& value) {
             if (key == "texture")
               source.texture = toTextureNode(where + ".texture", value.cast<py::dict>());
             if (key == "output") source.output = value.cast<std::string>();
             if (key == "primvar") source.primvar = value.cast<std::string>();
             if (key == "program") {
               const py::list nodes = value.cast<py::list>();
               for (size_t i = 0; i < nodes.size(); ++i)
                 source.program.push_back(toProgramNode(
                     where + ".program[" + std::to_string(i) + "]", nodes[i].cast<py::dict>()));
             }
             if (key == "fallback") {
               if (py::hasattr(value, "__len__"))
                 source.fallback = toFloats<3>(where + ".fallback", value);
               else
                 source.fallback.fill(value.cast<float>());
             }
           });
  if (int(source.texture.has_value()) + int(!source.primvar.empty()) +
          int(!source.program.empty()) !=
      1)
    throw std::invalid_argument(where +
                                ": a connection names one of a texture, a primvar or a program");
  return source;
}

}  // namespace

void bindMaterials(pybind11::module_& m, DelegateClass& delegate) {
  delegate.def(
      "set_material",
      [](RenderDelegate& self, const std::string& id, const py::dict& params) {
        Material& material = self.material(id);
        material.resetParams();
        for (const auto& [key, value] : params) {
          const std::string name = py::str(key);
          if (py::isinstance<py::dict>(value))
            material.connect(name, toInputSource(id + ": " + name, value.cast<py::dict>()));
          else
            material.setParam(name, toParamValue(id + ": " + name, value));
        }
      },
      py::arg("id"), py::arg("params"));
}

}  // namespace penumbra::bindings
