#pragma once
// The library reports failures by throwing sahbench::Error; only the CLI prints them and chooses an
// exit code. Messages name what failed and where (file, key, value) so a user can act on them.

#include <stdexcept>
#include <string>

namespace sahbench {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace sahbench
