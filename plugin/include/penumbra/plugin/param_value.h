// Typed access to ParamValue for the prims' parameter setters.
#pragma once

#include <stdexcept>
#include <string>

#include "penumbra/plugin/prim.h"

namespace penumbra::plugin {

/// A number as float (bool and int widen); throws std::invalid_argument naming the parameter.
float paramAsFloat(const std::string& name, const ParamValue& value);
bool paramAsBool(const std::string& name, const ParamValue& value);
Vec3f paramAsColor(const std::string& name, const ParamValue& value);
std::string paramAsString(const std::string& name, const ParamValue& value);

}  // namespace penumbra::plugin
