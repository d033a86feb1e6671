#pragma once
// Where the shared evaluation data is (stereo/, euroc/, kitti_odometry/: ../shared/data beside the project): the
// environment variable IPS_DATA_DIR when set, else the folder the build was configured with (the CMake cache entry
// IPS_DATA_DIR). One place for every tool and test, so that the data can move without a rebuild.
#include <string>

namespace ips {

std::string dataDir();
// dataDir() + "/" + relative.
std::string dataPath(const std::string& relative);

// A file or folder the project ships beside its programs (the viewer's page, the report's template): under an
// installed tree, PREFIX/share/ips/`relative` beside the running program's PREFIX/bin; in the build tree, where it
// is not installed, `source_path` (the source tree's copy, compiled in).
std::string installedFile(const std::string& relative, const std::string& source_path);

}  // namespace ips
