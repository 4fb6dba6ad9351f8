#include "penumbra/plugin/material.h"

#include <cmath>
#include <map>
#include <set>
#include <string>
#include <tuple>
#include <type_traits>
#include <variant>

#include "penumbra/material_inputs.h"
#include "penumbra/plugin/param_value.h"

namespace penumbra::plugin {
namespace {

template <typename Value>
Value parseToken(const std::map<std::string, Value>& tokens, const std::string& token,
                 const char* what) {
  const auto found = tokens.find(token);
  if (found != tokens.end()) return found->second;
  std::string known;
  for (const auto& [name, value] : tokens) known += (known.empty() ? "" : ", ") + name;
  throw std::invalid_argument("unknown " + std::string(what) + " '" + token + "' (expected " +
                              known + ")");
}

/// The files whose alpha channel `connections` read as opacity: a texture's "a" output, or a
/// program's swizzle of a texture's fourth channel. Every input of the material reads these
/// files' colour filtered as coverage (TextureAlpha::Coverage).
std::set<std::string> coverageFiles(
    const std::vector<std::pair<MaterialInput, InputSource>>& connections) {
  std::set<std::string> files;
  for (const auto& [input, source] : connections) {
    if (input != MaterialInput::Opacity) continue;
    if (source.texture && source.output == "a") files.insert(source.texture->file);
    for (const ProgramNode& node : source.program) {
      if (node.node.op != ExpressionOp::Swizzle || node.node.channels[0] != 3) continue;
      const ProgramNode& operand = source.program.at(node.node.operands[0]);
      if (operand.texture) files.insert(operand.texture->file);
    }
  }
  return files;
}

/// Opens `node`'s file for `material` (a warning when it cannot be, once per file in
/// `unreadable`: a texture node may drive several inputs) and appends its reader to `result`'s
/// textures; returns its index.
int openTexture(const Material& material, const TextureNode& node,
                const std::set<std::string>& coverage, SyncContext& context,
                penumbra::Material* result, std::set<std::string>* unreadable) {
  TextureReader reader = node.reader;
  std::string error;
  reader.texture = context.scene.materials().textures().open(
      node.file, node.colorSpace, &error,
      coverage.count(node.file) ? TextureAlpha::Coverage : TextureAlpha::Data);
  ++context.counters.materialTextureOpens;
  if (!error.empty() && unreadable->insert(node.file).second)
    context.warn(material.id() + ": " + error +
                 (reader.texture == TextureSystem::kInvalid
                      ? "; its fallback value is used"
                      : "; those UDIM tiles give the fallback value"));
  result->textures.push_back(std::move(reader));
  return int(result->textures.size() - 1);
}

}  // namespace

TextureWrap parseTextureWrap(const std::string& token) {
  static const std::map<std::string, TextureWrap> tokens = {
      {"black", TextureWrap::Black},
      {"clamp", TextureWrap::Clamp},
      {"repeat", TextureWrap::Repeat},
      {"mirror", TextureWrap::Mirror},
      {"useMetadata", TextureWrap::UseMetadata}};
  return parseToken(tokens, token, "wrap mode");
}

SourceColorSpace parseSourceColorSpace(const std::string& token) {
  static const std::map<std::string, SourceColorSpace> tokens = {{"auto", SourceColorSpace::Auto},
                                                                 {"raw", SourceColorSpace::Raw},
                                                                 {"sRGB", SourceColorSpace::SRGB}};
  return parseToken(tokens, token, "sourceColorSpace");
}

std::pair<int, int> parseTextureOutput(const std::string& token) {
  static const std::map<std::string, std::pair<int, int>> tokens = {
      {"rgb", {0, 3}}, {"r", {0, 1}}, {"g", {1, 1}}, {"b", {2, 1}}, {"a", {3, 1}}};
  return parseToken(tokens, token, "UsdUVTexture output");
}

void Material::setParam(const std::string& name, const ParamValue& value) {
  static const std::map<std::string, AnisotropyModel> anisotropyModels = {
      {"openPBR", AnisotropyModel::OpenPbr}, {"standardSurface", AnisotropyModel::StandardSurface}};
  try {
    const MaterialInputInfo* input = findMaterialInput(name);
    if (!input || std::holds_alternative<std::monostate>(input->member))
      throw std::invalid_argument("unknown UsdPreviewSurface input '" + name + "'");
    std::visit(
        [&](auto member) {
          using Member = decltype(member);
          if constexpr (std::is_same_v<Member, float MaterialParams::*>) {
            const float parsed = paramAsFloat(name, value);
            if (input->mustBeFinite && !std::isfinite(parsed))
              throw std::invalid_argument(name + " must be finite");
            params_.*member = parsed;
          } else if constexpr (std::is_same_v<Member, Vec3f MaterialParams::*>) {
            const Vec3f parsed = paramAsColor(name, value);
            if (input->mustBeFinite && !isFinite(parsed))
              throw std::invalid_argument(name + " must be finite");
            params_.*member = parsed;
          } else if constexpr (std::is_same_v<Member, bool MaterialParams::*> ||
                               std::is_same_v<Member, std::optional<bool> MaterialParams::*>) {
            params_.*member = paramAsBool(name, value);
          } else if constexpr (std::is_same_v<Member, AnisotropyModel MaterialParams::*>) {
            params_.*member =
                parseToken(anisotropyModels, paramAsString(name, value), "anisotropy model");
          }
        },
        input->member);
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(id() + ": " + error.what());
  }
  markDirty(DirtyParams);
}

void Material::connect(const std::string& input, InputSource source) {
  static const std::map<std::string, MaterialInput> inputs = [] {
    std::map<std::string, MaterialInput> result;
    for (const MaterialInputInfo& info : materialInputs())
      if (info.connectable) result.emplace(info.name, *info.connectable);
    return result;
  }();
  try {
    const MaterialInput connected = parseToken(inputs, input, "connectable input");
    if (source.texture) parseTextureOutput(source.output);
    if (!source.program.empty()) {
      // Texture indices are assigned at sync; check the rest now, with each texture node given
      // an index of its own.
      ExpressionProgram program;
      size_t textures = 0;
      for (const ProgramNode& node : source.program) {
        program.nodes.push_back(node.node);
        if (node.node.op == ExpressionOp::Texture) {
          if (!node.texture) throw std::invalid_argument("a texture node needs a texture");
          program.nodes.back().texture = int(textures++);
        }
      }
      if (const std::string problem = program.problem(textures); !problem.empty())
        throw std::invalid_argument(input + ": " + problem);
    }
    connections_.emplace_back(connected, std::move(source));
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(id() + ": " + error.what());
  }
  markDirty(DirtyParams);
}

void Material::resetParams() {
  params_ = MaterialParams{};
  connections_.clear();
  markDirty(DirtyParams);
}

void Material::sync(SyncContext& context, uint32_t) {
  penumbra::Material result;
  result.constants = params_;
  std::set<std::string> unreadable;
  const std::set<std::string> coverage = coverageFiles(connections_);
  for (const auto& [input, source] : connections_) {
    InputConnection connection;
    connection.input = input;
    if (!source.program.empty()) {
      ExpressionProgram program;
      for (const ProgramNode& node : source.program) {
        program.nodes.push_back(node.node);
        if (node.texture)
          program.nodes.back().texture =
              openTexture(*this, *node.texture, coverage, context, &result, &unreadable);
      }
      connection.program = int(result.programs.size());
      connection.channelCount = isVectorInput(input) ? 3 : 1;
      result.programs.push_back(std::move(program));
    } else if (source.texture) {
      connection.texture =
          openTexture(*this, *source.texture, coverage, context, &result, &unreadable);
      std::tie(connection.firstChannel, connection.channelCount) =
          parseTextureOutput(source.output);
    } else {
      connection.primvar = PrimvarName(source.primvar);
      connection.fallback = source.fallback;
    }
    result.connections.push_back(std::move(connection));
  }
  unreadableStamps_.clear();
  for (const std::string& file : unreadable) unreadableStamps_.emplace_back(file, fileStamp(file));
  ++context.counters.materialBuilds;
  context.sceneChanged = true;
  context.scene.setMaterial(size_t(context.materials.at(id())), std::move(result));
}

bool Material::unreadableFilesChanged() const {
  return anyChanged(unreadableStamps_);
}

void Material::finalize(SyncContext& context) {
  context.sceneChanged = true;
  context.materials.remove(id(), context.scene);
}

}  // namespace penumbra::plugin
