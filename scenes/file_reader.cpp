#include "scenes/file_reader.h"

#include <algorithm>
#include <cstring>

#include "core/error.h"

namespace sahbench {

namespace {

// Large enough that the per-chunk overhead vanishes against parsing, small enough to stay in L2.
constexpr std::size_t kChunkBytes = std::size_t{1} << 20;

bool is_space(char c) {
  return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}

}  // namespace

FileReader::FileReader(const std::filesystem::path& path)
    : name_(path.string()), file_(path, std::ios::binary), buffer_(kChunkBytes) {
  if (!file_) throw Error(name_ + ": cannot open file");
}

bool FileReader::refill() {
  if (pos_ > 0) {
    std::memmove(buffer_.data(), buffer_.data() + pos_, available());
    end_ -= pos_;
    pos_ = 0;
  }
  if (end_ == buffer_.size() || !file_) return false;
  file_.read(buffer_.data() + end_, static_cast<std::streamsize>(buffer_.size() - end_));
  const auto got = static_cast<std::size_t>(file_.gcount());
  end_ += got;
  return got > 0;
}

bool FileReader::read(void* dst, std::size_t count) {
  auto* out = static_cast<char*>(dst);
  // Small reads (the common case) come from the buffer; a read larger than the buffer is assembled in
  // pieces, and only consumed if it completes.
  if (count <= buffer_.size()) {
    while (available() < count)
      if (!refill()) return false;
    std::memcpy(out, buffer_.data() + pos_, count);
    pos_ += count;
    return true;
  }
  std::size_t done = 0;
  while (done < count) {
    if (available() == 0 && !refill()) return false;
    const std::size_t n = std::min(available(), count - done);
    std::memcpy(out + done, buffer_.data() + pos_, n);
    pos_ += n;
    done += n;
  }
  return true;
}

bool FileReader::skip(std::size_t count) {
  while (count > 0) {
    if (available() == 0 && !refill()) return false;
    const std::size_t n = std::min(available(), count);
    pos_ += n;
    count -= n;
  }
  return true;
}

bool FileReader::read_line(std::string& line, std::size_t max_length) {
  line.clear();
  token_line_ = line_;
  bool any = false;
  for (;;) {
    if (available() == 0 && !refill()) return any;
    any = true;
    const char* begin = buffer_.data() + pos_;
    const auto* newline = static_cast<const char*>(std::memchr(begin, '\n', available()));
    const std::size_t n = newline ? static_cast<std::size_t>(newline - begin) : available();
    if (line.size() + n > max_length)
      throw Error(name_ + ": line " + std::to_string(line_) + " is longer than " +
                  std::to_string(max_length) + " bytes");
    line.append(begin, n);
    pos_ += n;
    if (newline) {
      ++pos_;
      ++line_;
      if (!line.empty() && line.back() == '\r') line.pop_back();
      return true;
    }
  }
}

std::string_view FileReader::next_token() {
  // Skip whitespace, counting lines for error messages.
  for (;;) {
    if (available() == 0 && !refill()) return {};
    const char c = buffer_[pos_];
    if (!is_space(c)) break;
    if (c == '\n') ++line_;
    ++pos_;
  }
  token_line_ = line_;
  // Scan the token; if it runs into the end of the buffer, refill (which moves it to the front) and
  // scan on from where we were.
  std::size_t length = 0;
  for (;;) {
    while (pos_ + length < end_ && !is_space(buffer_[pos_ + length])) ++length;
    if (pos_ + length < end_) break;
    if (!refill()) {
      if (end_ == buffer_.size())
        throw Error(name_ + ": line " + std::to_string(line_) + ": token longer than " +
                    std::to_string(buffer_.size()) + " bytes");
      break;  // the token ends at the end of the file
    }
  }
  const std::string_view token(buffer_.data() + pos_, length);
  pos_ += length;
  return token;
}

}  // namespace sahbench
