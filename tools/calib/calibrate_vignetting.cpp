// calibrate_vignetting: both cameras' flat-field gain (CameraIntrinsics::vignetting_gain) from raw images: the head's
// LCM log (STEREO), or image files. The library (ips/calib/vignetting.hpp) does the work; this reads the images,
// prints the figures and writes the calibration with the gains. The last line is
// `corner_gain0=... corner_gain1=... residual0=... residual1=... images=...`.
#include <cstdio>
#include <ips/stereo_pair_t.hpp>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <vector>

#include "ips/args.hpp"
#include "ips/calib/figures.hpp"
#include "ips/calib/image_files.hpp"
#include "ips/calib/vignetting.hpp"
#include "ips/calibration.hpp"
#include "ips/framework/image.hpp"
#include "ips/framework/log_reader.hpp"
#include "ips/framework/validate.hpp"

namespace {

// Image file i of every N and its successor i + 1 (the tracks need consecutive images), as from a log.
void addFiles(const std::string& pattern, ips::calib::VignettingAccumulator& camera, int every) {
  const std::vector<std::string> files = ips::calib::matchingFiles(pattern);
  if (files.empty()) throw std::runtime_error("no image matches " + pattern);
  for (size_t i = 0; i < files.size(); ++i) {
    const bool successor = i > 0 && (i - 1) % static_cast<size_t>(every) == 0;
    if (i % static_cast<size_t>(every) != 0 && !successor) continue;
    const cv::Mat image = cv::imread(files[i], cv::IMREAD_GRAYSCALE);
    if (image.empty()) throw std::runtime_error(files[i] + ": cannot read the image");
    camera.add(image, successor);
  }
}

}  // namespace

int main(int argc, char** argv) {
  try {
    ips::Args args(argc, argv, "Both cameras' flat-field gain (vignetting) from raw images -> the calibration file");
    args.option("--log", "FILE.lcmlog", "the head's recording (or --left/--right)")
        .option("--stereo-channel", "NAME", "with --log: channel of ips::stereo_pair_t", "STEREO")
        .option("--left", "GLOB", "left raw images (quoted glob)")
        .option("--right", "GLOB", "right raw images")
        .required("--calib", "FILE", "the head's calibration (the lenses: the gain is a function of a ray's angle)")
        .option("--out", "FILE.yaml", "write --calib with both cameras' vignetting_gain and the figures")
        .option("--source", "scene|flat",
                "scene: the head moving through an ordinary scene, turning (each image row its own mean level); "
                "flat: a uniformly lit, even surface filling the view",
                "scene")
        .option("--every", "N", "use every N-th pair of a log (and its successor, for the tracks) or of the files", "1")
        .option("--min-images", "N", "fewer images are an error (default: 50 for scene, 5 for flat)")
        .option("--block", "PX", "the mean image is fitted in blocks of this size", "8")
        .epilog("Exit status: 0 estimated, 1 error, 2 bad command line.");
    if (!args.parse()) return 0;
    ips::StereoCalibration calib = ips::loadCalibration(args.get("--calib"));
    ips::calib::VignettingOptions options;
    const std::string source = args.get("--source");
    if (source != "scene" && source != "flat")
      throw ips::ArgError("calibrate_vignetting: --source must be scene or flat, got " + source);
    const bool flat = source == "flat";
    options.source = flat ? ips::calib::FlatFieldSource::kFlatTarget : ips::calib::FlatFieldSource::kMovingScene;
    // A moving scene averages out only over many views; a flat target needs a few images against the noise.
    options.min_images = args.has("--min-images") ? static_cast<int>(args.getInt("--min-images")) : flat ? 5 : 50;
    options.block_px = static_cast<int>(args.getInt("--block"));
    const int every = static_cast<int>(args.getInt("--every"));
    if (every < 1) throw ips::ArgError("calibrate_vignetting: --every must be at least 1");
    ips::calib::VignettingAccumulator cameras[2] = {ips::calib::VignettingAccumulator(calib.cam0, options),
                                                    ips::calib::VignettingAccumulator(calib.cam1, options)};
    long long bad = 0;
    if (args.has("--log")) {
      ips::fw::LogReader log(args.get("--log"));
      ips::fw::LogMessage event;
      const std::string channel = args.get("--stereo-channel");
      long long pairs = 0;
      int64_t previous_seq = -2;
      bool taken_previous = false;
      while (log.next(&event)) {
        if (event.channel != channel) continue;
        ips::stereo_pair_t m;
        if (m.decode(event.data.data(), 0, static_cast<int>(event.data.size())) < 0 || !ips::fw::validate(m).ok()) {
          ++bad;
          continue;
        }
        // Pair k of every N and its successor k + 1 (the tracks need consecutive images); a gap in the sequence
        // numbers (lost pairs) starts afresh.
        const bool successor = m.seq == previous_seq + 1 && taken_previous;
        previous_seq = m.seq;
        taken_previous = pairs++ % every == 0;
        if (!taken_previous && !successor) continue;
        // As E3D takes them: mono16 cameras give their upper 8 bits.
        cameras[0].add(ips::fw::mono8Copy(ips::fw::leftImage(m)), successor);
        cameras[1].add(ips::fw::mono8Copy(ips::fw::rightImage(m)), successor);
      }
    } else if (args.has("--left") && args.has("--right")) {
      addFiles(args.get("--left"), cameras[0], every);
      addFiles(args.get("--right"), cameras[1], every);
    } else {
      throw ips::ArgError("calibrate_vignetting: give --log, or --left and --right");
    }
    ips::calib::VignettingEstimate estimates[2];
    for (int c = 0; c < 2; ++c) {
      estimates[c] = cameras[c].estimate();
      const ips::calib::VignettingEstimate& e = estimates[c];
      std::printf(
          "camera %d: %d images, gain 1 + %.4f t + %.4f t^2 + %.4f t^3 (t = tan^2 of the ray's angle, up to %.3f in "
          "the corners): corners lifted %.3f x; flatness left %.2f %%\n",
          c, e.images, e.gain[0], e.gain[1], e.gain[2], e.widest_tan2, e.corner_gain, 100 * e.relative_residual);
    }
    if (bad > 0) std::printf("undecodable_or_invalid=%lld\n", bad);
    if (args.has("--out")) {
      calib.cam0.vignetting_gain = estimates[0].gain;
      calib.cam1.vignetting_gain = estimates[1].gain;
      calib.source = "estimated";
      const std::string from = args.has("--log") ? args.get("--log") : args.get("--left");
      ips::saveCalibration(args.get("--out"), calib, [&](cv::FileStorage& fs) {
        ips::calib::copyFigureBlocks(fs, args.get("--calib"), "vignetting_figures");
        fs << "vignetting_figures"
           << "{"
           << "date" << ips::calib::utcNow() << "images_from" << from << "source" << source << "images"
           << estimates[0].images << "corner_gain"
           << std::vector<double>{estimates[0].corner_gain, estimates[1].corner_gain} << "relative_residual"
           << std::vector<double>{estimates[0].relative_residual, estimates[1].relative_residual} << "}";
      });
      std::printf("wrote %s\n", args.get("--out").c_str());
    }
    std::printf("corner_gain0=%.4f corner_gain1=%.4f residual0=%.4f residual1=%.4f images=%d\n",
                estimates[0].corner_gain, estimates[1].corner_gain, estimates[0].relative_residual,
                estimates[1].relative_residual, estimates[0].images);
    return 0;
  } catch (const ips::ArgError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "calibrate_vignetting: %s\n", e.what());
    return 1;
  }
}
