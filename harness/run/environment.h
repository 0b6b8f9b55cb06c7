#pragma once
// Where a figure came from: commit, CPU, ISA, compiler and thread count. Printed with every result and
// written in every CSV row, so a number can be traced to the machine and code that produced it.

#include <string>

namespace sahbench {

struct Environment {
  std::string git_commit;  ///< the commit the binary was built from, "-dirty" with local changes
  std::string cpu;         ///< model name from /proc/cpuinfo
  std::string isa;         ///< widest vector ISA our kernels were compiled for (e.g. avx512, avx2, sse2)
  std::string compiler;    ///< e.g. "gcc 12.2.0"
  std::string embree;      ///< Embree version, and the ISA Embree was compiled with support for
};

Environment current_environment();

/// The commit stamped at build time (generated file).
const char* build_git_commit();

}  // namespace sahbench
