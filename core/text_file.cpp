#include "core/text_file.h"

#include <fstream>
#include <sstream>
#include <system_error>

#include "core/error.h"

namespace sahbench {

void require_file_path(const std::filesystem::path& path, std::string_view what) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw Error(path.string() + ": is a directory; give the path of a " + std::string(what) + " file");
}

std::string read_text_file(const std::filesystem::path& path, std::string_view what) {
  const std::string cannot = path.string() + ": cannot open the " + std::string(what);
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw Error(cannot + ": no such file");
  if (std::filesystem::is_directory(path, ec)) throw Error(cannot + ": it is a directory");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(cannot);
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw Error(path.string() + ": cannot read the " + std::string(what));
  return text.str();
}

}  // namespace sahbench
