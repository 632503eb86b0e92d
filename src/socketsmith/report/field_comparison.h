#pragma once
/// @file comparison.h
/// Agreement between two fields on the same points (socketsmith vs CalculiX, a donned socket vs
/// its design): mean absolute error and its standard deviation, RMSE, bias, Pearson R, high
/// percentiles and the largest error and where — the thesis's measures (ch. 3.6, 5.5) and more.

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace socketsmith::report {

struct ErrorStats {
  int count = 0;          ///< points compared
  double mae = 0;         ///< mean |a − b|
  double sd = 0;          ///< standard deviation of |a − b| (the thesis's "± x kPa")
  double rmse = 0;        ///< sqrt(mean (a − b)²)
  double bias = 0;        ///< mean (a − b)
  double r = 0;           ///< Pearson correlation; NaN when either field is constant or count < 2
  double max_error = 0;   ///< max |a − b|
  int max_index = -1;     ///< index (into the inputs) of max_error
  double p95 = 0;         ///< 95th percentile of |a − b| (nearest rank)
  double p99 = 0;         ///< 99th percentile of |a − b| (nearest rank)
  double mean_a = 0, mean_b = 0;
  double sd_a = 0, sd_b = 0;  ///< standard deviation of each field (R of a nearly flat field measures noise)
};

/// Statistics of @p a against @p b over @p subset (indices; all points when empty). Points where
/// either value is not finite are skipped.
/// @throws InvalidInputError when a and b differ in size or a subset index is out of range.
ErrorStats compare_fields(const std::vector<double>& a, const std::vector<double>& b, const std::vector<int>& subset = {});

/// The statistics scaled by @p scale (e.g. 1e-3 for Pa → kPa; r and count unchanged) as JSON:
/// {count, mae, sd, rmse, bias, r, max_err, max_index, p95, p99, mean_a, mean_b, sd_a, sd_b} with @p suffix appended to
/// the names of scaled values ("_kpa": mae_kpa, sd_kpa, max_err_kpa...). NaN becomes null.
nlohmann::json to_json(const ErrorStats& s, double scale = 1.0, const std::string& suffix = "");

/// Area-weighted means of some fields over one band of points (a ring of skin quads below the brim).
struct BandMeans {
  int band = 0;              ///< the band's number (1: the ring at the brim)
  int count = 0;             ///< points in it
  double area = 0;           ///< their summed weight
  std::vector<double> mean;  ///< one per field, Σ w v / Σ w
};

/// Each field of @p fields averaged over the points of each band 1..@p deepest with weights @p weight
/// (bands beyond @p deepest pooled into it; points in band < 1 left out, as are points where a field
/// is not finite or the weight is not positive). Bands without a point are not listed.
/// @throws InvalidInputError when the sizes differ or @p deepest < 1.
std::vector<BandMeans> band_means(const std::vector<int>& band, const std::vector<double>& weight,
                                  const std::vector<std::vector<double>>& fields, int deepest);

}  // namespace socketsmith::report
