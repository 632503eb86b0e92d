#include "socketsmith/scan/depth_image.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"

namespace socketsmith::scan {
namespace fs = std::filesystem;

int DepthImage::count_valid() const {
  return static_cast<int>(std::count_if(raw.begin(), raw.end(), [](std::uint16_t r) { return r != 0; }));
}

namespace {

/// Loads a single-channel image of any bit depth; @p what names the caller in messages.
cv::Mat read_gray_png(const fs::path& path, const char* what) {
  if (!fs::exists(path)) fail<IoError>("{}: cannot open '{}' (file not found)", what, path.string());
  cv::Mat m;
  try {
    m = cv::imread(path.string(), cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
  } catch (const cv::Exception& e) {
    fail<IoError>("{}: cannot decode '{}' ({})", what, path.string(), e.what());
  }
  if (m.empty()) fail<IoError>("{}: cannot decode '{}' (not a PNG/PGM image)", what, path.string());
  return m;
}

int bits_of(const cv::Mat& m) { return m.depth() == CV_8U || m.depth() == CV_8S ? 8 : m.depth() == CV_16U || m.depth() == CV_16S ? 16 : 32; }

/// Writes a 16-bit single-channel PNG atomically.
void write_u16_png(const fs::path& path, int width, int height, const std::vector<std::uint16_t>& data,
                   const char* what) {
  require(width > 0 && height > 0 && data.size() == static_cast<size_t>(width) * height,
          "{}: image {}x{} has {} values (expected width·height)", what, width, height, data.size());
  cv::Mat m(height, width, CV_16UC1, const_cast<std::uint16_t*>(data.data()));
  std::vector<uchar> buffer;
  if (!cv::imencode(".png", m, buffer)) fail<IoError>("{}: cannot encode '{}'", what, path.string());
  write_file_atomically(
      path, [&](std::ostream& os) { os.write(reinterpret_cast<const char*>(buffer.data()), buffer.size()); }, true);
}

void copy_u16(const cv::Mat& m, std::vector<std::uint16_t>& out) {
  out.resize(static_cast<size_t>(m.cols) * m.rows);
  for (int v = 0; v < m.rows; ++v) {
    const auto* row = m.ptr<std::uint16_t>(v);
    std::copy(row, row + m.cols, out.begin() + static_cast<std::ptrdiff_t>(v) * m.cols);
  }
}

}  // namespace

DepthImage read_depth_png(const fs::path& path, double scale_m) {
  require(std::isfinite(scale_m) && scale_m > 0.0, "read_depth_png: depth scale {} m per unit is not positive",
          scale_m);
  const cv::Mat m = read_gray_png(path, "read_depth_png");
  require(m.channels() == 1, "read_depth_png: '{}' has {} channels (expected a single-channel 16-bit depth image)",
          path.string(), m.channels());
  require(m.depth() == CV_16U,
          "read_depth_png: '{}' is {}-bit (expected 16-bit depth, e.g. in mm; an 8-bit PNG is a picture, not depth)",
          path.string(), bits_of(m));
  DepthImage d;
  d.width = m.cols;
  d.height = m.rows;
  d.scale_m = scale_m;
  copy_u16(m, d.raw);
  return d;
}

void write_depth_png(const fs::path& path, const DepthImage& image) {
  write_u16_png(path, image.width, image.height, image.raw, "write_depth_png");
}

IrImage read_ir_png(const fs::path& path) {
  cv::Mat m = read_gray_png(path, "read_ir_png");
  require(m.channels() == 1, "read_ir_png: '{}' has {} channels (expected a single-channel 8- or 16-bit IR image)",
          path.string(), m.channels());
  require(m.depth() == CV_8U || m.depth() == CV_16U,
          "read_ir_png: '{}' is not an unsigned 8- or 16-bit image (expected the sensor's IR amplitude)", path.string());
  if (m.depth() == CV_8U) m.convertTo(m, CV_16U, 257.0);
  IrImage ir;
  ir.width = m.cols;
  ir.height = m.rows;
  copy_u16(m, ir.value);
  return ir;
}

void write_ir_png(const fs::path& path, const IrImage& image) {
  write_u16_png(path, image.width, image.height, image.value, "write_ir_png");
}

FrameFusion parse_frame_fusion(const std::string& name, const std::string& what) {
  if (name == "median") return FrameFusion::Median;
  if (name == "trimmed-mean") return FrameFusion::TrimmedMean;
  fail("{}: frame fusion '{}' is not known (expected median or trimmed-mean)", what, name);
}

const char* frame_fusion_name(FrameFusion fusion) {
  return fusion == FrameFusion::Median ? "median" : "trimmed-mean";
}

DepthImage fuse_frames(const std::vector<DepthImage>& frames, FrameFusion fusion) {
  require(!frames.empty(), "fuse_frames: no frames");
  const DepthImage& f0 = frames.front();
  for (const DepthImage& f : frames)
    require(f.width == f0.width && f.height == f0.height && f.scale_m == f0.scale_m && f.raw.size() == f0.raw.size(),
            "fuse_frames: frames differ in size or scale ({}x{} vs {}x{}); a sensor's frames must match", f.width,
            f.height, f0.width, f0.height);
  if (frames.size() == 1) return f0;
  DepthImage out = f0;
  // The trimmed mean is kept on a finer grid: a tenth of the raw unit when the readings fit.
  int finer = 1;
  if (fusion == FrameFusion::TrimmedMean) {
    std::uint16_t top = 0;
    for (const DepthImage& f : frames) top = std::max(top, *std::max_element(f.raw.begin(), f.raw.end()));
    for (int k : {10, 5, 2})
      if (static_cast<long>(top) * k <= 65535) {
        finer = k;
        break;
      }
    out.scale_m = f0.scale_m / finer;
  }
  std::vector<std::uint16_t> values;
  for (size_t i = 0; i < out.raw.size(); ++i) {
    values.clear();
    for (const DepthImage& f : frames)
      if (f.raw[i] != 0) values.push_back(f.raw[i]);
    if (2 * values.size() < frames.size() || values.empty()) {
      out.raw[i] = 0;
      continue;
    }
    if (fusion == FrameFusion::Median) {
      auto mid = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
      std::nth_element(values.begin(), mid, values.end());
      out.raw[i] = *mid;
      continue;
    }
    std::sort(values.begin(), values.end());
    const size_t cut = values.size() / 4;
    double sum = 0.0;
    for (size_t q = cut; q < values.size() - cut; ++q) sum += values[q];
    const double mean = sum / static_cast<double>(values.size() - 2 * cut);
    out.raw[i] = static_cast<std::uint16_t>(std::clamp(std::round(mean * finer), 1.0, 65535.0));
  }
  return out;
}

IrImage mean_of_ir_frames(const std::vector<IrImage>& frames) {
  require(!frames.empty(), "mean_of_ir_frames: no frames");
  const IrImage& f0 = frames.front();
  for (const IrImage& f : frames)
    require(f.width == f0.width && f.height == f0.height && f.value.size() == f0.value.size(),
            "mean_of_ir_frames: frames differ in size ({}x{} vs {}x{})", f.width, f.height, f0.width, f0.height);
  if (frames.size() == 1) return f0;
  IrImage out = f0;
  for (size_t i = 0; i < out.value.size(); ++i) {
    double sum = 0.0;
    for (const IrImage& f : frames) sum += f.value[i];
    out.value[i] = static_cast<std::uint16_t>(std::round(sum / static_cast<double>(frames.size())));
  }
  return out;
}

DepthMap to_depth_map(const DepthImage& image, double depth_shift_m, int upsample, double max_jump_m) {
  require(upsample >= 1 && upsample <= 8, "to_depth_map: upsample factor {} is out of range (expected 1 to 8)",
          upsample);
  const int w = image.width, h = image.height;
  auto metres = [&](int u, int v) -> double {
    const std::uint16_t r = image.at(u, v);
    return r == 0 ? 0.0 : r * image.scale_m + depth_shift_m;
  };
  DepthMap m;
  m.width = w * upsample;
  m.height = h * upsample;
  m.depth_m.assign(static_cast<size_t>(m.width) * m.height, 0.0f);
  if (upsample == 1) {
    for (int v = 0; v < h; ++v)
      for (int u = 0; u < w; ++u) m.depth_m[static_cast<size_t>(v) * w + u] = static_cast<float>(std::max(0.0, metres(u, v)));
    return m;
  }
  for (int V = 0; V < m.height; ++V) {
    const double y = (V + 0.5) / upsample - 0.5;
    const int v0 = std::clamp(static_cast<int>(std::floor(y)), 0, h - 1), v1 = std::min(v0 + 1, h - 1);
    const double fy = std::clamp(y - v0, 0.0, 1.0);
    for (int U = 0; U < m.width; ++U) {
      const double x = (U + 0.5) / upsample - 0.5;
      const int u0 = std::clamp(static_cast<int>(std::floor(x)), 0, w - 1), u1 = std::min(u0 + 1, w - 1);
      const double fx = std::clamp(x - u0, 0.0, 1.0);
      const double d00 = metres(u0, v0), d10 = metres(u1, v0), d01 = metres(u0, v1), d11 = metres(u1, v1);
      const double lo = std::min({d00, d10, d01, d11}), hi = std::max({d00, d10, d01, d11});
      double d;
      if (lo > 0.0 && hi - lo <= max_jump_m) {
        d = (1 - fy) * ((1 - fx) * d00 + fx * d10) + fy * ((1 - fx) * d01 + fx * d11);
      } else {
        const int un = fx < 0.5 ? u0 : u1, vn = fy < 0.5 ? v0 : v1;
        d = metres(un, vn);
      }
      m.depth_m[static_cast<size_t>(V) * m.width + U] = static_cast<float>(std::max(0.0, d));
    }
  }
  return m;
}

}  // namespace socketsmith::scan
