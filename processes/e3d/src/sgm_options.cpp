#include "ips/e3d/sgm_options.hpp"

#include <cstdio>
#include <stdexcept>
#include <string>

#include "ips/config.hpp"

namespace ips {
namespace e3d {

void addSgmOptions(ips::Args& args) {
  const SgmParams d;
  const auto penalties = [](Cost cost) {
    const SgmParams c = SgmParams::forCost(cost);
    return std::string(toString(cost)) + " " + std::to_string(c.p1) + "/" + std::to_string(c.p2) + "/" +
           std::to_string(c.p2_slope);
  };
  const auto yesNo = [](bool on) { return on ? std::string("on") : std::string("off"); };
  const SgmParams mi_pixelwise = SgmParams::forCost(Cost::mi, 1);
  const std::string per_cost = "(default P1/P2/p2_slope per cost: " + penalties(Cost::census) + ", " +
                               penalties(Cost::ad) + ", " + penalties(Cost::sad) + ", " + penalties(Cost::mi) +
                               ";\nmi with --mi-window 1: " + std::to_string(mi_pixelwise.p1) + "/" +
                               std::to_string(mi_pixelwise.p2) + "/" + std::to_string(mi_pixelwise.p2_slope) + ")";
  args.option("--config", "FILE",
              "SGM: YAML with a section 'sgm' (SgmParams keys), e.g. config/e3d.yaml; the SGM options below\n"
              "start from it, without it from the built-in defaults shown")
      .option("--cost", "census|ad|sad|mi",
              "matching cost (default " + std::string(toString(d.cost)) +
                  "; another cost than the config's takes that cost's penalties)")
      .option("--mi-levels", "N",
              "levels of the Mutual Information hierarchy (default " + std::to_string(d.mi_levels) + ")")
      .option("--mi-coarse-iterations", "N",
              "iterations on the coarse levels of the Mutual Information hierarchy (default " +
                  std::to_string(d.mi_coarse_iterations) + ")")
      .option("--mi-window", "1|3",
              "Mutual Information: the cost's window, 1 = pixelwise, 3 = mean over 3x3; another window\nthan the "
              "config's takes its penalties (default " +
                  std::to_string(d.mi_window) + ")")
      .option("--mi-regions", "CxR",
              "Mutual Information: one table per region of a C x R grid (1x1 = one table; default " +
                  std::to_string(d.mi_region_columns) + "x" + std::to_string(d.mi_region_rows) + ")")
      .option("--mi-region-min-pixels", "N",
              "Mutual Information: a level takes the regions when each holds N pixels, else one table\n(default " +
                  std::to_string(d.mi_region_min_pixels) + ")")
      .option("--num-disparities", "N",
              "1.." + std::to_string(kMaxDisparities) + " (default " + std::to_string(d.num_disparities) + ")")
      .option("--min-disparity", "N", "(default " + std::to_string(d.min_disparity) + ")")
      .option("--p1", "N", "penalty in cost units for a disparity change of 1 px")
      .option("--p2", "N", "penalty in cost units for larger changes (p2 + the cost's maximum, 24 or 63, <= 255)")
      .option("--p2-slope", "N", "adaptive P2 = max(P1, P2 - N*|dI|/16), 0 = off\n" + per_cost)
      .option("--paths", "8|4", "(default " + std::to_string(d.paths) + ")")
      .option("--uniqueness", "PERCENT", "0 = off (default " + std::to_string(d.uniqueness) + ")")
      .option("--lr-max-diff", "PX", "< 0 = no left-right check (default " + std::to_string(d.lr_max_diff) + ")")
      .flag("--no-subpixel", "no subpixel disparities (default: subpixel " + yesNo(d.subpixel) + ")")
      .flag("--no-median", "no median filter (default: median " + yesNo(d.median) + ")")
      .flag("--fill", "dense product: invalid pixels take the background of their row neighbours\n(default " +
                          yesNo(d.fill_invalid) + ": invalid pixels stay invalid)")
      .option("--right-map", "diagonal|match",
              "right map for the check: diagonal search, or a second match right to left (default " +
                  std::string(toString(d.right_map)) + ")")
      .option("--aggregation", "auto|rows|lines",
              "how the device walks the paths (same results; auto: rows on a CPU device)\n(default " +
                  std::string(toString(d.aggregation)) + ")")
      .option("--row-pixels", "N",
              "row passes: pixels per subgroup, a power of two up to the subgroup size (same results; 0 = chosen\n"
              "from the range, default " +
                  std::to_string(d.row_pixels) + ")")
      .option("--search", "full|narrowed",
              "full range at every pixel, or a band around the half-resolution match (default " +
                  std::string(toString(d.search)) + ")")
      .option("--band-width", "PX", "narrowed: the band's width (default " + std::to_string(d.band_width) + ")")
      .option(
          "--band-margin", "PX",
          "narrowed: added on both sides of the coarse disparities (default " + std::to_string(d.band_margin) + ")");
}

SgmParams sgmParamsFromArgs(const ips::Args& a) {
  SgmParams p;
  if (a.has("--config")) p = SgmParams::fromConfig(Config(a.get("--config")).section("sgm"));
  if (a.has("--cost")) {
    const Cost cost = parseCost(a.get("--cost"));
    if (cost != p.cost) p = p.withCost(cost);
  }
  const auto setIfGiven = [&](const char* name, int& value) {
    if (a.has(name)) value = static_cast<int>(a.getInt(name));
  };
  if (a.has("--mi-window")) {
    const int window = static_cast<int>(a.getInt("--mi-window"));
    if (window != p.mi_window) {
      p.mi_window = window;
      if (p.cost == Cost::mi) p = p.withCost(Cost::mi);  // mi's penalties for this window; other costs keep theirs
    }
  }
  setIfGiven("--mi-levels", p.mi_levels);
  setIfGiven("--mi-coarse-iterations", p.mi_coarse_iterations);
  if (a.has("--mi-regions")) {
    const std::string grid = a.get("--mi-regions");
    char rest = 0;
    if (std::sscanf(grid.c_str(), "%dx%d%c", &p.mi_region_columns, &p.mi_region_rows, &rest) != 2)
      throw std::invalid_argument("--mi-regions: expected COLUMNSxROWS (e.g. 6x3), got '" + grid + "'");
  }
  setIfGiven("--mi-region-min-pixels", p.mi_region_min_pixels);
  setIfGiven("--num-disparities", p.num_disparities);
  setIfGiven("--min-disparity", p.min_disparity);
  setIfGiven("--p1", p.p1);
  setIfGiven("--p2", p.p2);
  setIfGiven("--p2-slope", p.p2_slope);
  setIfGiven("--paths", p.paths);
  setIfGiven("--uniqueness", p.uniqueness);
  setIfGiven("--lr-max-diff", p.lr_max_diff);
  if (a.getFlag("--no-subpixel")) p.subpixel = false;
  if (a.getFlag("--no-median")) p.median = false;
  if (a.getFlag("--fill")) p.fill_invalid = true;
  if (a.has("--right-map")) p.right_map = parseRightMap(a.get("--right-map"));
  if (a.has("--aggregation")) p.aggregation = parseAggregation(a.get("--aggregation"));
  if (a.has("--search")) p.search = parseSearch(a.get("--search"));
  setIfGiven("--row-pixels", p.row_pixels);
  setIfGiven("--band-width", p.band_width);
  setIfGiven("--band-margin", p.band_margin);
  p.validate();
  return p;
}

}  // namespace e3d
}  // namespace ips
