#pragma once
// Buffered sequential reading of a scene file, for the hand-written parsers: whole chunks are read at
// once and bytes, lines and whitespace-separated tokens are taken from the buffer.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

namespace sahbench {

class FileReader {
 public:
  /// Opens `path`; throws Error ("PATH: cannot open file") when it cannot.
  explicit FileReader(const std::filesystem::path& path);

  /// The path as given, for error messages.
  const std::string& name() const { return name_; }

  /// Copies the next `count` bytes to `dst`; false if the file ends first (nothing is consumed then).
  bool read(void* dst, std::size_t count);
  /// Skips `count` bytes; false if the file ends first.
  bool skip(std::size_t count);

  /// The next line without its "\n" or "\r\n"; false at end of file. Throws Error if a line is longer
  /// than `max_length` (a binary file read as text would otherwise fill memory).
  bool read_line(std::string& line, std::size_t max_length);

  /// The next whitespace-separated token, or an empty view at end of file. The view is valid until the
  /// next call. Throws Error for a token longer than the buffer.
  std::string_view next_token();

  /// 1-based number of the line where the last token (or line) started.
  std::size_t line_number() const { return token_line_; }

 private:
  /// Moves the unread bytes to the front and appends more from the file; false if none were added.
  bool refill();
  std::size_t available() const { return end_ - pos_; }

  std::string name_;
  std::ifstream file_;
  std::vector<char> buffer_;
  std::size_t pos_ = 0;  // next unread byte
  std::size_t end_ = 0;  // one past the last valid byte
  std::size_t line_ = 1;
  std::size_t token_line_ = 1;
};

}  // namespace sahbench
