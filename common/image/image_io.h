// Image output and input: multi-layer linear EXR (docs/ARCHITECTURE.md §9 channel names) and
// tone-mapped PNG.
#pragma once

#include <map>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace rtpm {

class FrameImage;

/// One RGB layer to write: `name` "" gives channels R G B, otherwise name.R name.G name.B.
/// `rgb` holds width·height·3 linear floats, row-major from the top-left pixel.
struct ImageLayer {
    std::string name;
    std::span<const float> rgb;
};

/// Every writer below writes a temporary file in the destination's folder, flushes it to disk and
/// renames it over `path`: a reader (or a second process writing the same path) sees the old
/// image or the new one, never a partial file, and a failed write leaves the old file as it was.

/// The two files an image output (--out) names: an EXR and a PNG beside it with the same stem.
struct ImageOutputPaths {
    std::string exr, png;
};

/// "x.exr" and "x.png" (any letter case) both give x.exr and x.png; any other extension throws
/// OutputError naming the path and the fix (a JPEG or extension-less name would otherwise hold
/// an EXR, and a .png name would have its EXR overwritten by the PNG). Check the two paths with
/// prepareOutputFile (common/core/output_file.h) before rendering.
ImageOutputPaths imageOutputPaths(const std::string& out);

/// Header attributes of an EXR file: name → text, written as OpenEXR string attributes (what
/// `oiiotool --info -v` and `exrheader` list). rtpm's names: image_metadata.h.
using ExrAttributes = std::map<std::string, std::string>;

/// Writes a multi-layer OpenEXR file (zip compression, float32 or half) with `attributes` in its
/// header. Non-finite values are written as 0. Throws std::runtime_error naming the file on any
/// I/O error, or std::invalid_argument if a layer's size is not width·height·3, two layers share
/// a name or an attribute name is one OpenEXR reserves.
void writeExr(const std::string& path, int width, int height, std::span<const ImageLayer> layers,
              bool half = false, const ExrAttributes& attributes = {});

/// Writes a frame with the docs/ARCHITECTURE.md §9 channels: R G B (final), direct.*, caustic.*,
/// caustic_filtered.* (the buffers of `frame`, which must have been composed).
void writeExr(const std::string& path, const FrameImage& frame, bool half = false,
              const ExrAttributes& attributes = {});

/// The path of frame `frame`'s numbered copy of output `out`: `<dir>/<stem>_<frame, 5 digits><ext>`
/// (rtpm-render and rtpm-server --save-every write the same names).
std::string numberedPath(const std::string& out, uint64_t frame, const char* ext);

/// A decoded image: every channel as its own plane of width·height floats, keyed by name.
struct ExrImage {
    int width = 0;
    int height = 0;
    std::vector<std::string> channelNames;  ///< in the file's order
    std::map<std::string, std::vector<float>> channels;
    ExrAttributes attributes;  ///< the header's string attributes (EXR only)

    /// Interleaved RGB of layer `name` ("" = R G B). Throws std::out_of_range if a channel is missing.
    std::vector<float> layerRgb(const std::string& name) const;
};

/// Reads an OpenEXR file, or a PNG, JPEG, HDR, … that stb_image decodes (8- and 16-bit values
/// scaled to [0, 1] as stored, channels Y, YA, RGB or RGBA), as float channels.
/// Throws std::runtime_error naming the file if it cannot be opened or decoded.
ExrImage readExr(const std::string& path);

/// Tone mapping for PNG output. The operator: scale every channel by 2^exposureStops (or, when
/// unset, by the automatic exposure 1 / (99th-percentile luminance of the image), so the brightest
/// 1% of pixels clip and a lone hot pixel cannot darken the frame, times 2^stopsAboveAuto), clamp
/// to [0, 1], apply the sRGB transfer curve (IEC 61966-2-1) and quantise to 8 bits with rounding.
/// Non-finite values become black.
struct ToneMap {
    std::optional<float> exposureStops;
    float stopsAboveAuto = 0.0f;  ///< RenderSettings::exposure; 0 leaves the automatic scale as is
};

/// Writes an 8-bit sRGB PNG of linear RGB `rgb` (width·height·3, row-major from the top).
/// Returns the linear scale factor that was applied (useful to keep a sequence's exposure fixed).
/// Throws std::runtime_error naming the file on I/O errors, std::invalid_argument on a bad size.
float writePng(const std::string& path, int width, int height, std::span<const float> rgb,
               const ToneMap& toneMap = {});

/// The scale writePng's automatic exposure picks: 1 / (99th-percentile Rec.709 luminance), or 1
/// when that percentile is zero or not finite. Cost O(W·H) (nth_element).
float autoExposureScale(std::span<const float> rgb);

/// sRGB transfer curve (linear [0, 1] → encoded [0, 1]).
float linearToSrgb(float v);

}  // namespace rtpm
