// ips_report: the main job's report. Reads the LCM logs recorded while the system ran (filter states, tracker
// deltas, disparity maps, health, and the simulator's ground truth) and writes report.json with the figures of the
// run, and report.html: one self-contained page (report_page.html filled with the run's data) that draws the figures
// table, the trajectories against ground truth, the filters' errors with their 3-sigma bounds and NEES, the tracker's
// inliers and the processes' latency over time, disparity examples with colour bars beside ground truth and the error
// map, and one of them triangulated into a 3D point cloud. The run's PNG pictures are screenshots of that page
// (tools/report/render_pictures.sh). The figures are the evaluation library's (ips/eval/run_report.hpp), section by
// section; this main reads the options, writes the files and says how the run went.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>

#include "ips/calibration.hpp"
#include "ips/data_dir.hpp"
#include "ips/eval/run_report.hpp"
#include "ips/framework/process.hpp"
#include "ips/mapper/voxel_map.hpp"
#include "ips/sim/scenario.hpp"
#include "ips/sim/world.hpp"
#include "report_page.hpp"

namespace {

// The map on the page: every voxel up to this many (a building's map of a few 100 000 voxels is thinned evenly).
constexpr size_t kMaxMapPagePoints = 120000;

std::vector<std::string> splitList(const std::string& text) {
  std::vector<std::string> items;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) items.push_back(item);
  return items;
}

std::vector<double> numbers(const std::string& option, const std::string& text) {
  std::vector<double> out;
  for (const std::string& item : splitList(text)) {
    try {
      out.push_back(std::stod(item));
    } catch (const std::exception&) {
      throw ips::ArgError(option + ": '" + item + "' is not a number");
    }
  }
  return out;
}

void writeNees(const std::string& path, const std::string& channel, const ips::eval::ErrorSeries& err) {
  // The NEES over time for a Monte Carlo over seeds (ips_seeds, IPS_SEEDS in the main job).
  std::ofstream nees_file(path);
  nees_file << "# t [s since the run's first state] and the position NEES (3 dof) of " << channel << "\n";
  for (size_t i = 0; i < err.t.size(); ++i)
    nees_file << err.t[i] << " " << (std::isfinite(err.nees[i]) ? std::to_string(err.nees[i]) : "nan") << "\n";
}

}  // namespace

int main(int argc, char** argv) {
  return ips::fw::guardedMain("ips_report", [&]() {
    ips::Args args(argc, argv, "report of a run: trajectory errors, disparity quality, process figures");
    args.required(
            "--log", "FILE[,FILE]",
            "LCM log recorded during the run (filter states, deltas, disparity, health, GT), or its parts in order")
        .option("--states-log", "FILE[,FILE]",
                "the recording of the filters' states and the ground truth, or its parts in order, where the run had a "
                "recorder of its own for them")
        .option("--bulk-log", "FILE[,FILE]",
                "the recording of the bulk bus (disparity maps, points), or its parts in order, where the run had one")
        .option("--images", "FILE", "the input log with STEREO pairs (for the disparity pictures)")
        .option("--calib", "FILE", "the head's true calibration (for evaluation: rectifying the pictures' images)")
        .option("--process-calib", "FILE",
                "the calibration the processes ran on, whose source the report names; default: --calib")
        .option("--filters", "CH[,CH]", "filter state channels and their names", "FILTER_STATE,FILTER_STATE_UKF")
        .option("--pictures", "N", "disparity maps shown as examples on the page", "3")
        .option("--map", "FILE", "the mapper's map (PLY/PCD) placed with the filter's poses, shown and scored")
        .option("--map-gt-poses", "FILE", "the same maps placed with the ground truth's poses (scored beside it)")
        .option("--map-poses", "filter|tracker",
                "what placed the --map: the filter's states or the tracker's increments", "filter")
        .option(
            "--world-seed", "N",
            "the simulated world the run saw (the sim's --seed): the maps' points are scored against its surfaces,\n"
            "and sim_effects lists what its scenario switched on")
        .option("--world-scenario", "FILE", "its scenario file (default: the built-in walk)")
        .option("--map-up", "X,Y,Z|truth",
                "the map's up direction, for the top view, in a world not levelled by an IMU: e.g. 0,-1,0 for a "
                "camera frame; truth: the map's world is the body at the first image and the ground truth's "
                "attitude there says where up is",
                "0,0,1")
        .option("--lengths", "M[,M]",
                "sub-sequence lengths of the relative errors (KITTI devkit style); default 10,20,40 m when the "
                "ground truth is longer than 40 m, else 1,2 m")
        .option("--page-template", "FILE",
                "the report page's HTML template (default: PREFIX/share/ips/report/report_page.html when installed)",
                ips::installedFile("report/report_page.html", IPS_REPORT_PAGE_TEMPLATE))
        .option("--js-dir", "DIR",
                "where Debian's libjs-chart.js and libjs-three are (chart.js/, three/), inlined into the page",
                IPS_JS_DIR)
        .flag("--keep-truth-steps",
              "judge against the ground truth's positions as recorded, steps included (default: a step no head\n"
              "can make between two samples, 5 g, is taken off the later positions; ground_truth_steps_removed)")
        .required("--out", "DIR", "output folder (report.json and report.html)");
    if (!args.parse()) return 0;
    namespace ev = ips::eval;
    if (args.getInt("--pictures") < 0) throw ips::ArgError("ips_report: --pictures must not be negative");
    const std::string out = args.get("--out");
    std::error_code mkdir_error;
    std::filesystem::create_directories(out, mkdir_error);
    if (mkdir_error) throw std::runtime_error("cannot create the output folder " + out + ": " + mkdir_error.message());
    // The simulated world's scenario (--world-seed), read once: its effects and its surfaces for the map.
    std::optional<ips::sim::Scenario> world_scenario;
    if (args.has("--world-seed")) {
      world_scenario = args.has("--world-scenario") ? ips::sim::Scenario::load(args.get("--world-scenario"))
                                                    : ips::sim::Scenario::defaults();
      world_scenario->seed = static_cast<uint64_t>(args.getInt("--world-seed"));
    }
    // Both calibrations read once, before any log: a bad file ends the report at once, naming itself.
    std::optional<ips::StereoCalibration> truth_calib;
    if (args.has("--calib")) truth_calib = ips::loadCalibration(args.get("--calib"));
    const std::optional<ips::StereoCalibration> ran_on =
        args.has("--process-calib") ? std::optional(ips::loadCalibration(args.get("--process-calib"))) : truth_calib;
    // What the processes ran on: "true", "perturbed", "estimated", "converted", or "unspecified".
    const std::string calibration_source = ran_on && !ran_on->source.empty() ? ran_on->source : "unspecified";
    std::vector<double> lengths;
    if (args.has("--lengths")) {
      lengths = numbers("--lengths", args.get("--lengths"));
      if (lengths.empty()) throw ips::ArgError("--lengths: no length given");
      for (double l : lengths)
        if (!(l > 0)) throw ips::ArgError("--lengths: every length must be positive");
    }
    std::optional<Eigen::Vector3d> map_up;  // none: from the truth
    if (args.get("--map-up") != "truth") {
      const std::vector<double> up = numbers("--map-up", args.get("--map-up"));
      if (up.size() != 3 || !(std::hypot(up[0], up[1], up[2]) > 0))
        throw ips::ArgError("--map-up takes three numbers, not all zero: '" + args.get("--map-up") + "'");
      map_up = Eigen::Vector3d(up[0], up[1], up[2]).normalized();
    }

    ev::RunLogFiles files{splitList(args.get("--log")), splitList(args.get("--states-log")),
                          splitList(args.get("--bulk-log"))};
    if (files.results.empty()) throw ips::ArgError("--log: no file given");
    ev::RunLog log = ev::readRunLog(files, splitList(args.get("--filters")));
    // Every estimator is judged against the same truth, without the steps it holds (ev::removePositionSteps).
    std::vector<ev::PositionStep> truth_steps;
    if (!args.getFlag("--keep-truth-steps")) truth_steps = ev::removePositionSteps(log.gt);
    // What makes the run's figures untrustworthy: named in report.json ("failures") and on stderr, exit 4.
    std::vector<std::string> failures = log.failures;
    std::optional<int64_t> input_end;
    ev::InputLog input;  // its truth's end and its IMU: both judged against the run's truth alone
    if (args.has("--images") && !log.gt.empty()) {
      input = ev::readInputLog(args.get("--images"), failures);
      input_end = input.truth_end_us;
    }
    for (auto& f : ev::completenessFailures(log, args.get("--log"), input_end)) failures.push_back(std::move(f));
    // What disturbed a run that is complete: named with the time, and the run's status says so.
    std::vector<std::string> warnings = ev::disturbances(log);

    const double t0 = ev::pageStartTime(log);  // the page's time axis
    ev::Json report = ev::overviewSection(log);
    report["ground_truth_steps_removed"] = truth_steps.size();
    double largest_step = 0;
    for (const auto& step : truth_steps) largest_step = std::max(largest_step, step.step.norm());
    report["ground_truth_step_max_m"] = largest_step;
    const ev::FiltersSection filters =
        ev::filtersSection(log, truth_calib, ran_on, t0, ips::report::kMaxPageErrorSamples);
    report.update(filters.json);
    for (const auto& f : filters.results) {
      writeNees(out + "/nees_" + f.channel + ".tsv", f.channel, f.errors);
      ev::writeTum(out + "/trajectory_" + f.channel + ".tum", f.aligned);
    }
    if (!log.gt.empty()) ev::writeTum(out + "/trajectory_ground_truth.tum", log.gt);
    // The filters estimate the body (IMU frame) like the ground truth; the tracker's chained increments give camera
    // 0, judged against the ground truth carried to camera 0.
    const ev::EstimatorsSection estimators =
        ev::estimatorsSection(log, truth_calib ? truth_calib->T_imu_cam0 : Eigen::Isometry3d::Identity(),
                              lengths.empty() ? ev::defaultRpeLengths(ev::distanceTravelled(log.gt)) : lengths);
    report.update(estimators.json);
    report.update(ev::spanNoiseSection(log, input.imu, estimators.tracker, truth_calib));
    warnings.insert(warnings.end(), estimators.warnings.begin(), estimators.warnings.end());
    if (!log.delta_msgs.empty()) {
      if (!estimators.truth_cam0.empty())
        ev::writeTum(out + "/trajectory_ground_truth_cam0.tum", estimators.truth_cam0);
      ev::writeTum(out + "/trajectory_tracker.tum", estimators.tracker);
    }
    const std::vector<ev::DisparityScore> scores = ev::disparityScores(log);
    report.update(ev::disparitySection(log, scores));

    std::string page_map = "null";
    if (args.has("--map")) {
      std::vector<uint8_t> grey;
      const std::vector<Eigen::Vector3d> map = ips::mapper::VoxelMap::load(args.get("--map"), &grey);
      std::optional<std::vector<Eigen::Vector3d>> map_gt;
      if (args.has("--map-gt-poses")) map_gt = ips::mapper::VoxelMap::load(args.get("--map-gt-poses"));
      std::optional<ips::sim::World> world;
      if (world_scenario) world = ips::sim::World::build(world_scenario->world, world_scenario->seed);
      report.update(ev::mapSection(log, map, map_gt, world ? &*world : nullptr));
      if (!map_up) {
        if (log.gt.empty() || log.delta_msgs.empty())
          throw ips::ArgError("--map-up truth needs the ground truth and the tracker's increments in the recording");
        map_up = ev::mapUpFromTruth(log);
      }
      page_map = ips::report::mapJson(
          map, grey, kMaxMapPagePoints, *map_up,
          args.get("--map-poses") == "tracker" ? "the tracker\u2019s increments" : "the filter\u2019s states");
    }

    ips::report::DisparityExamples examples;
    if (args.has("--images") && truth_calib && !log.est_disp.empty()) {
      examples = ips::report::disparityExamples(args.get("--images"), *truth_calib, log, scores,
                                                static_cast<int>(args.getInt("--pictures")), t0, failures);
      report["disparity_pictures"] = examples.examples.size();
    }
    report.update(ev::processesSection(log));
    report["bad_messages"] = log.bad_messages + examples.bad;
    report["calibration_source"] = calibration_source;
    // On the simulator: what made its scenario harder than the built-in walk (ips::sim::simEffects).
    if (world_scenario) report["sim_effects"] = ips::sim::simEffects(*world_scenario);
    report["calibration_figures"] =
        ev::calibrationFigures(args.has("--process-calib") ? args.get("--process-calib") : args.get("--calib"));
    report["status"] = ev::runStatus(failures, warnings);
    report["warnings"] = warnings;
    report["failures"] = failures;
    const std::string text = report.dump(2, ' ', false, ev::Json::error_handler_t::replace) + "\n";
    std::ofstream report_file(out + "/report.json");
    report_file << text;
    report_file.close();
    if (!report_file) throw std::runtime_error(out + "/report.json: cannot write (disk full?)");

    // The page: report.json's figures and the series it draws, filled into the template with the libraries.
    const std::string js_dir = args.get("--js-dir");
    ips::report::writePage(args.get("--page-template"),
                           {{"/*@CHART_JS@*/", js_dir + "/chart.js/chart.min.js"},
                            {"/*@THREE_JS@*/", js_dir + "/three/three.min.js"},
                            {"/*@ORBIT_CONTROLS_JS@*/", js_dir + "/three/examples/js/controls/OrbitControls.js"}},
                           ips::report::pageData(report, out, t0, log, filters, estimators, examples, page_map),
                           out + "/report.html");
    std::fputs(text.c_str(), stdout);
    for (const auto& w : warnings) std::fprintf(stderr, "ips_report: disturbed: %s\n", w.c_str());
    for (const auto& f : failures) std::fprintf(stderr, "ips_report: FAILED: %s\n", f.c_str());
    return failures.empty() ? 0 : 4;
  });
}
