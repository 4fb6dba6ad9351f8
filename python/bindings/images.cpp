// Image files (read, write, headers) and colour management (display transforms, OCIO colour
// spaces), over the renderer's image I/O.
#include <pybind11/stl.h>

#include <array>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include "bindings.h"
#include "conversions.h"
#include "penumbra/image_io.h"
#include "penumbra/texture.h"

namespace penumbra::bindings {

void bindImages(py::module_& m) {
  m.def(
      "write_image",
      [](const std::string& path, const FloatArray& channels, const std::vector<std::string>& names,
         const py::dict& metadata, const std::string& colorMode, const std::string& ocioConfig,
         const std::string& display, const std::string& view, const std::vector<bool>& halfChannels,
         const std::optional<std::array<int, 4>>& dataWindow) {
        if (channels.ndim() != 3 || channels.shape(2) != py::ssize_t(names.size()))
          throw std::invalid_argument(
              path + ": pixels must have shape (H, W, C) with one name per channel");
        ImageData image;
        image.height = int(channels.shape(0));
        image.width = int(channels.shape(1));
        image.channelNames = names;
        image.pixels.assign(channels.data(), channels.data() + channels.size());
        image.metadata = toMetadata(metadata);
        image.halfChannels.assign(halfChannels.begin(), halfChannels.end());
        if (dataWindow) {
          const auto [x, y, displayWidth, displayHeight] = *dataWindow;
          if (displayWidth <= 0 || displayHeight <= 0)
            throw std::invalid_argument(path + ": the data window's frame must have a size");
          image.x = x;
          image.y = y;
          image.displayWidth = displayWidth;
          image.displayHeight = displayHeight;
        }
        DisplaySettings settings{toColorCorrection(colorMode), ocioConfig, display, view};
        py::gil_scoped_release release;
        penumbra::writeImage(path, image, settings);
      },
      py::arg("path"), py::arg("channels"), py::arg("channel_names"),
      py::arg("metadata") = py::dict(), py::arg("color_mode") = "disabled",
      py::arg("ocio_config") = "", py::arg("display") = "", py::arg("view") = "",
      py::arg("half_channels") = std::vector<bool>(), py::arg("data_window") = std::nullopt);

  m.def(
      "display_pixels",
      [](const FloatArray& pixels, const std::string& colorMode, const std::string& ocioConfig,
         const std::string& display, const std::string& view) {
        if (pixels.ndim() != 3 || pixels.shape(2) < 3)
          throw std::invalid_argument("pixels must have shape (H, W, C) with C >= 3");
        const int height = int(pixels.shape(0)), width = int(pixels.shape(1));
        const int channels = int(pixels.shape(2));
        std::vector<float> values(pixels.data(), pixels.data() + pixels.size());
        {
          py::gil_scoped_release release;
          penumbra::applyDisplayTransform(
              values, width, height, channels,
              {toColorCorrection(colorMode), ocioConfig, display, view});
        }
        py::array_t<float> result({pixels.shape(0), pixels.shape(1), pixels.shape(2)});
        std::memcpy(result.mutable_data(), values.data(), values.size() * sizeof(float));
        return result;
      },
      py::arg("pixels"), py::arg("color_mode") = "openColorIO", py::arg("ocio_config") = "",
      py::arg("display") = "", py::arg("view") = "",
      "Pixels with the display transform applied to their first three channels.");

  m.def(
      "read_image",
      [](const std::string& path) {
        ImageData image;
        {
          py::gil_scoped_release release;
          image = penumbra::readImage(path);
        }
        const py::ssize_t channels = py::ssize_t(image.channelNames.size());
        py::array_t<float> pixels({py::ssize_t(image.height), py::ssize_t(image.width), channels});
        std::memcpy(pixels.mutable_data(), image.pixels.data(),
                    image.pixels.size() * sizeof(float));
        return py::make_tuple(pixels, image.channelNames, toDict(image.metadata));
      },
      py::arg("path"));

  m.def(
      "read_image_header",
      [](const std::string& path) {
        ImageData image;
        {
          py::gil_scoped_release release;
          image = penumbra::readImageHeader(path);
        }
        return py::make_tuple(image.width, image.height, image.channelNames,
                              toDict(image.metadata));
      },
      py::arg("path"),
      "(width, height, channel_names, metadata) of an image file, without its pixels.");

  m.def(
      "find_texture_color_space",
      [](const std::string& name, const std::string& ocioConfig) {
        return penumbra::findTextureColorSpace(ocioConfig, name);
      },
      py::arg("name"), py::arg("ocio_config") = "",
      "The name of the colour space `name` denotes in the OCIO config (empty: $OCIO), as texture "
      "colorSpace accepts it; \"\" when the config has none.");

  m.def(
      "to_scene_linear",
      [](std::array<float, 3> rgb, const std::string& name,
         const std::string& ocioConfig) -> std::optional<std::array<float, 3>> {
        if (!penumbra::convertToSceneLinear(ocioConfig, name, rgb.data())) return std::nullopt;
        return rgb;
      },
      py::arg("rgb"), py::arg("color_space"), py::arg("ocio_config") = "",
      "`rgb` converted from the named colour space to the OCIO config's scene_linear role (as "
      "textures in that colour space are); None when the config has no such colour space.");
}

}  // namespace penumbra::bindings
