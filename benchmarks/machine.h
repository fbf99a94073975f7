// The machine line every benchmark prints first: CPU, cores, MuJoCo, compiler, build type.
#ifndef PNEUMATIC_BENCHMARKS_MACHINE_H_
#define PNEUMATIC_BENCHMARKS_MACHINE_H_

#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <thread>

#include <mujoco/mujoco.h>

namespace pneumatic::benchmarks {

// the CPU's model name from /proc/cpuinfo
inline std::string CpuModel() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  std::string line;
  while (std::getline(cpuinfo, line)) {
    if (line.rfind("model name", 0) != 0) continue;
    size_t colon = line.find(':');
    if (colon != std::string::npos) return line.substr(line.find_first_not_of(" \t", colon + 1));
  }
  return "unknown CPU";
}

inline std::string Compiler() {
#if defined(__clang__)
  return std::string("Clang ") + __clang_version__;
#elif defined(__GNUC__)
  return std::string("GCC ") + __VERSION__;
#else
  return "unknown compiler";
#endif
}

// "Machine: <cpu>, <n> cores, MuJoCo <version>, <compiler>, <build type> build."
inline void PrintMachine(const char* build_type) {
  std::printf("Machine: %s, %u cores, MuJoCo %s, %s, %s build.\n\n", CpuModel().c_str(),
              std::thread::hardware_concurrency(), mj_versionString(), Compiler().c_str(),
              std::strlen(build_type) ? build_type : "unspecified");
}

}  // namespace pneumatic::benchmarks

#endif  // PNEUMATIC_BENCHMARKS_MACHINE_H_
