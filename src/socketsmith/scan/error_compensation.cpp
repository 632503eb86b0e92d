#include "socketsmith/scan/error_compensation.h"

#include <cmath>
#include <fstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "socketsmith/core/atomic_file.h"
#include "socketsmith/core/errors.h"
#include "socketsmith/core/json_input.h"

namespace socketsmith::scan {
namespace fs = std::filesystem;

void write_compensation_json(const fs::path& path, const std::vector<ErrorCompensation>& models) {
  require(!models.empty(), "write_compensation_json: no sensor models to write");
  nlohmann::ordered_json j;
  j["format"] = "socketsmith-scan-compensation";
  j["version"] = 1;
  j["model"] = models.front().form == CompensationForm::RayPolynomial ? "ray-poly" : "linear-uvd";
  j["comment"] = "linear-uvd: P_corrected = (I - diag(e_x, e_y, e_z)) P; e_k = c0 + cu*u + cv*v + cd*d (u, v: sensor "
                 "pixels, d: metres). ray-poly (per sensor): d' = d - depth_poly . (1, x, y, x^2, xy, y^2, d, d^2, ..., "
                 "d^depth_degree), "
                 "a = lateral . (1, x, y, d), P' = (x (1 - a_x) d', y (1 - a_y) d', d') with x = X/Z, y = Y/Z";
  j["sensors"] = nlohmann::ordered_json::array();
  for (const ErrorCompensation& m : models) {
    nlohmann::ordered_json s;
    s["name"] = m.sensor;
    s["width"] = m.width;
    s["height"] = m.height;
    if (m.form == CompensationForm::RayPolynomial) {
      s["model"] = "ray-poly";
      require(m.depth_polynomial.size() == 6 + m.depth_degree,
              "write_compensation_json: sensor '{}': {} depth coefficients for degree {} (expected {})", m.sensor,
              m.depth_polynomial.size(), m.depth_degree, 6 + m.depth_degree);
      s["depth_degree"] = m.depth_degree;
      s["depth_poly"] = std::vector<double>(m.depth_polynomial.data(), m.depth_polynomial.data() + m.depth_polynomial.size());
      s["lateral_x"] = {m.lateral(0, 0), m.lateral(0, 1), m.lateral(0, 2), m.lateral(0, 3)};
      s["lateral_y"] = {m.lateral(1, 0), m.lateral(1, 1), m.lateral(1, 2), m.lateral(1, 3)};
    } else {
      s["model"] = "linear-uvd";
      const char* keys[3] = {"e_x", "e_y", "e_z"};
      for (int k = 0; k < 3; ++k)
        s[keys[k]] = {m.coefficients(k, 0), m.coefficients(k, 1), m.coefficients(k, 2), m.coefficients(k, 3)};
    }
    s["frames"] = m.frames;
    s["corners"] = m.corners;
    s["truth"] = m.truth;
    j["sensors"].push_back(s);
  }
  write_text_atomically(path, j.dump(2) + "\n");
}

std::vector<ErrorCompensation> read_compensation_json(const fs::path& path) {
  std::ifstream in(path);
  if (!in) fail<IoError>("read_compensation_json: cannot open '{}' (write it with socketsmith scan calibrate)", path.string());
  nlohmann::json j = parse_json_stream(in, path.string(), "read_compensation_json");
  require(j.is_object() && j.value("format", std::string()) == "socketsmith-scan-compensation",
          "read_compensation_json: '{}' is not a compensation model (expected \"format\": "
          "\"socketsmith-scan-compensation\", written by socketsmith scan calibrate)",
          path.string());
  require(j.contains("sensors") && j["sensors"].is_array() && !j["sensors"].empty(),
          "read_compensation_json: '{}' has no \"sensors\" array", path.string());
  std::vector<ErrorCompensation> out;
  for (const auto& s : j["sensors"]) {
    ErrorCompensation m;
    try {
      m.sensor = s.at("name").get<std::string>();
      m.width = s.at("width").get<int>();
      m.height = s.at("height").get<int>();
      // Coefficient array @p key of @p n finite numbers.
      auto numbers = [&](const char* key, size_t n) {
        const auto c = s.at(key).get<std::vector<double>>();
        require(c.size() == n, "read_compensation_json: '{}': sensor '{}': {} has {} coefficients (expected {})",
                path.string(), m.sensor, key, c.size(), n);
        for (double x : c)
          require(std::isfinite(x), "read_compensation_json: '{}': sensor '{}': {} is not finite", path.string(),
                  m.sensor, key);
        return c;
      };
      const std::string form = s.value("model", j.value("model", std::string("linear-uvd")));
      require(form == "linear-uvd" || form == "ray-poly",
              "read_compensation_json: '{}': sensor '{}': model '{}' is not known (expected linear-uvd or ray-poly)",
              path.string(), m.sensor, form);
      if (form == "ray-poly") {
        m.form = CompensationForm::RayPolynomial;
        m.depth_degree = s.value("depth_degree", 3);
        require(m.depth_degree >= 1 && m.depth_degree <= ErrorCompensation::kMaxDepthDegree,
                "read_compensation_json: '{}': sensor '{}': depth_degree {} (expected 1 to {})", path.string(),
                m.sensor, m.depth_degree, ErrorCompensation::kMaxDepthDegree);
        const auto dp = numbers("depth_poly", static_cast<size_t>(6 + m.depth_degree)), lx = numbers("lateral_x", 4),
                   ly = numbers("lateral_y", 4);
        m.depth_polynomial = Eigen::Map<const Eigen::VectorXd>(dp.data(), static_cast<long>(dp.size()));
        for (int q = 0; q < 4; ++q) {
          m.lateral(0, q) = lx[static_cast<size_t>(q)];
          m.lateral(1, q) = ly[static_cast<size_t>(q)];
        }
      } else {
        const char* keys[3] = {"e_x", "e_y", "e_z"};
        for (int k = 0; k < 3; ++k) {
          const auto c = numbers(keys[k], 4);
          for (int q = 0; q < 4; ++q) m.coefficients(k, q) = c[static_cast<size_t>(q)];
        }
      }
      m.frames = s.value("frames", 0);
      m.corners = s.value("corners", 0);
      m.truth = s.value("truth", std::string());
    } catch (const nlohmann::json::exception& e) {
      fail("read_compensation_json: '{}': a sensor entry is malformed ({}; expected name, width, height, e_x, e_y, e_z)",
           path.string(), e.what());
    }
    require(m.width > 0 && m.height > 0, "read_compensation_json: '{}': sensor '{}' has image size {}x{}", path.string(),
            m.sensor, m.width, m.height);
    out.push_back(m);
  }
  return out;
}

const ErrorCompensation& compensation_for(const std::vector<ErrorCompensation>& models, const std::string& sensor,
                                          int width, int height, const std::string& source) {
  std::string names;
  for (const ErrorCompensation& m : models) {
    if (m.sensor == sensor) {
      require(m.width == width && m.height == height,
              "compensation '{}' was learned on {}x{} frames but sensor '{}' has {}x{} frames (a model for another "
              "sensor or resolution; run scan calibrate on this sensor's board frames)",
              source, m.width, m.height, sensor, width, height);
      return m;
    }
    names += (names.empty() ? "" : ", ") + m.sensor;
  }
  fail("compensation '{}' has no model for sensor '{}' (it has {}; run scan calibrate on this sensor's board frames)",
       source, sensor, names);
}

}  // namespace socketsmith::scan
