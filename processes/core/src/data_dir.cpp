#include "ips/data_dir.hpp"

#include <cstdlib>
#include <filesystem>
#include <system_error>

namespace ips {

std::string dataDir() {
  const char* env = std::getenv("IPS_DATA_DIR");
  return env && *env ? std::string(env) : std::string(IPS_DEFAULT_DATA_DIR);
}

std::string dataPath(const std::string& relative) { return dataDir() + "/" + relative; }

std::string installedFile(const std::string& relative, const std::string& source_path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path program = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = program.parent_path().parent_path() / "share" / "ips" / relative;
    if (fs::exists(installed, ec)) return installed.string();
  }
  return source_path;
}

}  // namespace ips
