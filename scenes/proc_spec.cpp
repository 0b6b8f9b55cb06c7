#include "scenes/proc_spec.h"

#include <charconv>
#include <cmath>
#include <limits>

#include "core/error.h"

namespace sahbench {

namespace {

constexpr std::string_view kPrefix = "proc:";

template <typename T>
std::optional<T> parse_number(std::string_view text) {
  T value{};
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size()) return std::nullopt;
  return value;
}

std::string format_real(double v) {
  char buf[64];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  return ec == std::errc() ? std::string(buf, end) : std::to_string(v);
}

std::string join_names(const auto& items) {
  std::string out;
  for (const auto& item : items) out += (out.empty() ? "" : ", ") + std::string(item.name);
  return out;
}

}  // namespace

std::optional<uint64_t> parse_count(std::string_view text) {
  double scale = 1.0;
  if (!text.empty() && (text.back() == 'k' || text.back() == 'K')) scale = 1e3;
  if (!text.empty() && text.back() == 'M') scale = 1e6;
  if (scale != 1.0) text.remove_suffix(1);
  // Plain integers are parsed as integers (exact); a suffix allows a decimal mantissa ("1.5M").
  if (scale == 1.0) {
    const auto v = parse_number<uint64_t>(text);
    if (!v || *v == 0 || *v > (uint64_t{1} << 53)) return std::nullopt;
    return v;
  }
  const auto mantissa = parse_number<double>(text);
  if (!mantissa || !std::isfinite(*mantissa)) return std::nullopt;
  const double v = *mantissa * scale;
  if (v < 1.0 || v > 0x1.0p53 || v != std::floor(v)) return std::nullopt;
  return static_cast<uint64_t>(v);
}

std::size_t ProcSpec::index(std::string_view name) const {
  for (std::size_t i = 0; i < kind_->params.size(); ++i)
    if (kind_->params[i].name == name) return i;
  // A programming error in a generator, not a user error, but still reported rather than UB.
  throw Error("proc:" + std::string(kind_->name) + ": no parameter '" + std::string(name) + "'");
}

std::string ProcSpec::normalised() const {
  std::string out = std::string(kPrefix) + std::string(kind_->name);
  for (std::size_t i = 0; i < kind_->params.size(); ++i) {
    const ProcParamInfo& p = kind_->params[i];
    out += i == 0 ? ':' : ',';
    out += p.name;
    out += '=';
    out += p.type == ProcParamType::kReal ? format_real(reals_[i]) : std::to_string(integers_[i]);
  }
  return out;
}

ProcSpec parse_proc_spec(std::string_view spec, std::span<const ProcKindInfo> kinds) {
  const std::string where(spec);
  if (!spec.starts_with(kPrefix)) throw Error(where + ": a procedural spec starts with 'proc:'");
  std::string_view rest = spec.substr(kPrefix.size());
  const std::size_t colon = rest.find(':');
  const std::string_view kind_name = rest.substr(0, colon);
  std::string_view params = colon == std::string_view::npos ? std::string_view{} : rest.substr(colon + 1);

  const ProcKindInfo* kind = nullptr;
  for (const ProcKindInfo& k : kinds)
    if (k.name == kind_name) kind = &k;
  if (!kind)
    throw Error(where + ": unknown procedural kind '" + std::string(kind_name) +
                "' (known: " + join_names(kinds) + ")");

  const std::size_t n = kind->params.size();
  std::vector<uint64_t> integers(n, 0);
  std::vector<double> reals(n, 0.0);
  std::vector<bool> given(n, false);
  for (std::size_t i = 0; i < n; ++i) {
    integers[i] = static_cast<uint64_t>(kind->params[i].default_value);
    reals[i] = kind->params[i].default_value;
  }

  // "proc:KIND" and "proc:KIND:" take every default; otherwise each comma-separated item is key=value.
  bool more = !params.empty();
  while (more) {
    const std::size_t comma = params.find(',');
    const std::string_view item = params.substr(0, comma);
    more = comma != std::string_view::npos;
    if (more) params.remove_prefix(comma + 1);
    const std::size_t eq = item.find('=');
    if (eq == std::string_view::npos)
      throw Error(where + ": expected key=value, got '" + std::string(item) + "'");
    const std::string_view key = item.substr(0, eq);
    const std::string_view text = item.substr(eq + 1);

    std::size_t i = 0;
    while (i < n && kind->params[i].name != key) ++i;
    if (i == n)
      throw Error(where + ": unknown parameter '" + std::string(key) + "' for '" + std::string(kind->name) +
                  "' (known: " + join_names(kind->params) + ")");
    if (given[i]) throw Error(where + ": parameter '" + std::string(key) + "' given twice");
    given[i] = true;

    const ProcParamInfo& p = kind->params[i];
    auto bad = [&](std::string_view expected) {
      return Error(where + ": bad value '" + std::string(text) + "' for '" + std::string(key) +
                   "' (expected " + std::string(expected) + ")");
    };
    const std::string range = "in [" + format_real(p.min) + ", " + format_real(p.max) + "]";
    switch (p.type) {
      case ProcParamType::kCount: {
        const auto v = parse_count(text);
        if (!v || static_cast<double>(*v) < p.min || static_cast<double>(*v) > p.max)
          throw bad("a count such as 1000, 100k or 1M, " + range);
        integers[i] = *v;
        break;
      }
      case ProcParamType::kInteger: {
        const auto v = parse_number<uint64_t>(text);
        // The bound is checked in double; integer parameters with a finite max are small.
        if (!v || static_cast<double>(*v) < p.min || static_cast<double>(*v) > p.max)
          throw bad("a whole number " + range);
        integers[i] = *v;
        break;
      }
      case ProcParamType::kReal: {
        const auto v = parse_number<double>(text);
        if (!v || !std::isfinite(*v) || *v < p.min || *v > p.max) throw bad("a number " + range);
        reals[i] = *v;
        break;
      }
    }
  }
  return ProcSpec(*kind, std::move(integers), std::move(reals));
}

}  // namespace sahbench
