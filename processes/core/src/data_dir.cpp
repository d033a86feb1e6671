#include "ips/data_dir.hpp"

#include <cstdlib>

namespace ips {

std::string dataDir() {
  const char* env = std::getenv("IPS_DATA_DIR");
  return env && *env ? std::string(env) : std::string(IPS_DEFAULT_DATA_DIR);
}

std::string dataPath(const std::string& relative) { return dataDir() + "/" + relative; }

}  // namespace ips
