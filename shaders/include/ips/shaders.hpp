#pragma once
// SPIR-V of the compute shaders in shaders/*.comp, embedded at build time.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace ips {

struct ShaderCode {
  const uint32_t* words = nullptr;
  size_t word_count = 0;
};

// The SPIR-V of shaders/<name>.comp; throws std::out_of_range naming the shader if there is none.
const ShaderCode& shaderCode(const std::string& name);

// Names of all embedded shaders (sorted).
std::vector<std::string> shaderNames();

}  // namespace ips
