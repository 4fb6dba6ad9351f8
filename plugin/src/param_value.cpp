#include "penumbra/plugin/param_value.h"

namespace penumbra::plugin {

float paramAsFloat(const std::string& name, const ParamValue& value) {
  if (const auto* number = std::get_if<float>(&value)) return *number;
  if (const auto* integer = std::get_if<int>(&value)) return float(*integer);
  if (const auto* flag = std::get_if<bool>(&value)) return *flag ? 1.0f : 0.0f;
  throw std::invalid_argument(name + " expects a number");
}

bool paramAsBool(const std::string& name, const ParamValue& value) {
  if (const auto* flag = std::get_if<bool>(&value)) return *flag;
  if (const auto* integer = std::get_if<int>(&value)) return *integer != 0;
  throw std::invalid_argument(name + " expects a bool or an int");
}

std::string paramAsString(const std::string& name, const ParamValue& value) {
  if (const auto* text = std::get_if<std::string>(&value)) return *text;
  throw std::invalid_argument(name + " expects a string");
}

Vec3f paramAsColor(const std::string& name, const ParamValue& value) {
  if (const auto* color = std::get_if<Vec3f>(&value)) return *color;
  throw std::invalid_argument(name + " expects a 3-component colour");
}

}  // namespace penumbra::plugin
