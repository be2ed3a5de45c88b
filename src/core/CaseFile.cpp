#include "core/CaseFile.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

namespace cassini {
namespace {

// Splits "a.b[2].c" or "a.b.2.c" into path components; numbers index arrays.
std::vector<std::string> split_key(const std::string& key) {
  std::vector<std::string> parts;
  std::string cur;
  for (char c : key) {
    if (c == '.' || c == '[' || c == ']') {
      if (!cur.empty()) parts.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (!cur.empty()) parts.push_back(cur);
  return parts;
}

bool is_index(const std::string& s) {
  return !s.empty() && s.find_first_not_of("0123456789") == std::string::npos;
}

// Canonical spelling used in messages and in the used-key set: "species[0].radius".
std::string canonical(const std::vector<std::string>& parts) {
  std::string out;
  for (const auto& p : parts) {
    if (is_index(p)) out += "[" + p + "]";
    else out += (out.empty() ? "" : ".") + p;
  }
  return out;
}

std::string describe(const toml::node& n) {
  std::ostringstream os;
  if (n.is_table()) return "a table";
  if (n.is_array()) return "an array";
  if (auto s = n.value<std::string>(); s && n.is_string()) return "the string \"" + *s + "\"";
  if (n.is_boolean()) return *n.value<bool>() ? "true" : "false";
  if (n.is_integer()) return std::to_string(*n.value<int64_t>());
  if (auto d = n.value<double>()) { os << *d; return os.str(); }
  return "a date/time";
}

// Parses the right-hand side of --set as TOML; bare words become strings.
toml::table parse_override_value(const std::string& value) {
  try {
    return toml::parse("v = " + value);
  } catch (const toml::parse_error&) {
    toml::table t;
    t.insert("v", value);
    return t;
  }
}

void apply_override(toml::table& root, const std::string& assignment, const std::string& source) {
  const auto eq = assignment.find('=');
  if (eq == std::string::npos || eq == 0)
    throw ConfigError("--set '" + assignment + "': expected KEY=VALUE, e.g. time.end=1.0");
  const auto parts = split_key(assignment.substr(0, eq));
  toml::table value = parse_override_value(assignment.substr(eq + 1));
  toml::node* node = &root;
  for (std::size_t i = 0; i + 1 < parts.size(); ++i) {
    if (auto* t = node->as_table()) {
      if (!t->contains(parts[i])) t->insert(parts[i], toml::table{});
      node = t->get(parts[i]);
    } else if (auto* a = node->as_array(); a && is_index(parts[i])) {
      const auto idx = std::stoul(parts[i]);
      if (idx >= a->size())
        throw ConfigError(source + ": --set " + assignment + ": index " + parts[i] + " is out of range");
      node = a->get(idx);
    } else {
      throw ConfigError(source + ": --set " + assignment + ": '" + parts[i] + "' is not a table");
    }
  }
  auto* target = node->as_table();
  if (!target) throw ConfigError(source + ": --set " + assignment + ": parent is not a table");
  target->insert_or_assign(parts.back(), *value.get("v"));
}

void collect_leaves(const toml::node& n, std::vector<std::string>& path, std::vector<std::string>& out) {
  if (auto* t = n.as_table()) {
    for (auto&& [k, v] : *t) {
      path.emplace_back(k.str());
      collect_leaves(v, path, out);
      path.pop_back();
    }
  } else if (auto* a = n.as_array(); a && a->is_array_of_tables() && !a->empty()) {
    for (std::size_t i = 0; i < a->size(); ++i) {
      path.push_back(std::to_string(i));
      collect_leaves(*a->get(i), path, out);
      path.pop_back();
    }
  } else {
    out.push_back(canonical(path));
  }
}

// Edit distance, for "did you mean" hints.
std::size_t distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] != b[j - 1])});
      diag = up;
    }
  }
  return row[b.size()];
}

// The candidate closest to `key` if it is a plausible typo of it, else "".
std::string closest(const std::string& key, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_d = std::max<std::size_t>(2, key.size() / 4) + 1;
  for (const auto& c : candidates)
    if (const std::size_t d = distance(key, c); d < best_d) { best = c; best_d = d; }
  return best;
}

}  // namespace

CaseFile CaseFile::parse(const std::string& text, const std::string& source,
                         const std::vector<std::string>& overrides) {
  CaseFile cf;
  cf.source_ = source;
  try {
    cf.table_ = toml::parse(text, source);
  } catch (const toml::parse_error& err) {
    std::ostringstream os;
    os << source << ":" << err.source().begin.line << ":" << err.source().begin.column
       << ": not valid TOML: " << err.description();
    throw ConfigError(os.str());
  }
  for (const auto& o : overrides) apply_override(cf.table_, o, source);
  return cf;
}

CaseFile CaseFile::load(const std::string& path, const std::vector<std::string>& overrides) {
  if (!std::filesystem::exists(path)) throw ConfigError(path + ": no such case file");
  if (std::filesystem::is_directory(path))
    throw ConfigError(path + ": is a directory, expected a TOML case file");
  if (!std::filesystem::is_regular_file(path))  // a FIFO or a device would block the read forever
    throw ConfigError(path + ": not a regular file (a pipe, socket or device), expected a TOML case file");
  std::ifstream in(path);
  if (!in) throw ConfigError(path + ": cannot open the case file: " + std::strerror(errno));
  std::stringstream ss;
  ss << in.rdbuf();
  return parse(ss.str(), path, overrides);
}

std::string CaseFile::directory() const {
  return std::filesystem::path(source_).parent_path().string();
}

const toml::node* CaseFile::find(const std::string& key) const {
  const toml::node* node = &table_;
  for (const auto& p : split_key(key)) {
    if (auto* t = node->as_table()) node = t->get(p);
    else if (auto* a = node->as_array(); a && is_index(p)) node = a->get(std::stoul(p));
    else return nullptr;
    if (!node) return nullptr;
  }
  return node;
}

bool CaseFile::has(const std::string& key) const { return find(key) != nullptr; }

void CaseFile::fail(const std::string& key, const std::string& expected) const {
  const auto* n = find(key);
  const std::string name = canonical(split_key(key));
  std::string got = n ? ", got " + describe(*n) : " (key missing)";
  if (!n) {  // often a typo, or a misspelt table: name what was written instead
    std::vector<std::string> leaves, path, unknown;
    collect_leaves(table_, path, leaves);
    for (const auto& leaf : leaves)
      if (!used_.count(leaf)) unknown.push_back(leaf);
    if (const std::string near = closest(name, unknown); !near.empty())
      got = " (key missing; the file has '" + near + "', which cassini does not know: a typo?)";
  }
  throw ConfigError(source_ + ": key '" + name + "': expected " + expected + got);
}

namespace {
std::string text_of(double v) {  // the shortest text that reads back as v
  for (int digits = 6;; ++digits) {
    std::ostringstream os;
    os << std::setprecision(digits) << v;
    if (digits >= 17 || std::strtod(os.str().c_str(), nullptr) == v) return os.str();
  }
}
std::string text_of(long v) { return std::to_string(v); }
std::string text_of(bool v) { return v ? "true" : "false"; }
std::string text_of(const std::string& v) { return "\"" + v + "\""; }
std::string text_of(const Vec3& v) { return "[" + text_of(v[0]) + ", " + text_of(v[1]) + ", " + text_of(v[2]) + "]"; }
template <class T>
std::string text_of(const std::vector<T>& v) {
  std::string out = "[";
  for (std::size_t k = 0; k < v.size(); ++k) out += (k ? ", " : "") + text_of(v[k]);
  return out + "]";
}
}  // namespace

template <class T>
T CaseFile::note(const std::string& key, T value) {
  resolved_[canonical(split_key(key))] = text_of(value);
  return value;
}

void CaseFile::record(const std::string& key, double value) { resolved_[canonical(split_key(key))] = text_of(value); }
void CaseFile::forget(const std::string& key) { resolved_.erase(canonical(split_key(key))); }

double CaseFile::positive(const std::string& key, std::optional<double> fallback) {
  const double v = number(key, fallback);
  if (!(v > 0)) fail(key, "a positive number");
  return v;
}

double CaseFile::non_negative(const std::string& key, std::optional<double> fallback) {
  const double v = number(key, fallback);
  if (v < 0) fail(key, "a number >= 0");
  return v;
}

double CaseFile::number(const std::string& key, std::optional<double> fallback) {
  mark(canonical(split_key(key)));
  const auto* n = find(key);
  if (!n) {
    if (fallback) return note(key, *fallback);
    fail(key, "a number");
  }
  if (auto v = n->value<double>()) {  // integers are accepted as numbers
    if (!std::isfinite(*v)) fail(key, "a finite number");
    return note(key, *v);
  }
  fail(key, "a number");
}

long CaseFile::integer(const std::string& key, std::optional<long> fallback) {
  mark(canonical(split_key(key)));
  const auto* n = find(key);
  if (!n) {
    if (fallback) return note(key, *fallback);
    fail(key, "an integer");
  }
  if (n->is_integer()) return note(key, static_cast<long>(*n->value<int64_t>()));
  fail(key, "an integer");
}

bool CaseFile::boolean(const std::string& key, std::optional<bool> fallback) {
  mark(canonical(split_key(key)));
  const auto* n = find(key);
  if (!n) {
    if (fallback) return note(key, *fallback);
    fail(key, "true or false");
  }
  if (n->is_boolean()) return note(key, *n->value<bool>());
  fail(key, "true or false");
}

std::string CaseFile::string(const std::string& key, std::optional<std::string> fallback) {
  mark(canonical(split_key(key)));
  const auto* n = find(key);
  if (!n) {
    if (fallback) return note(key, *fallback);
    fail(key, "a string");
  }
  if (n->is_string()) return note(key, *n->value<std::string>());
  fail(key, "a string");
}

Vec3 CaseFile::vec3(const std::string& key, std::optional<Vec3> fallback) {
  mark(canonical(split_key(key)));
  const auto* n = find(key);
  if (!n) {
    if (fallback) return note(key, *fallback);
    fail(key, "an array of 3 numbers");
  }
  const auto* a = n->as_array();
  if (!a || a->size() != 3) fail(key, "an array of 3 numbers");
  Vec3 v;
  for (int i = 0; i < 3; ++i) {
    auto x = a->get(i)->value<double>();
    if (!x || !std::isfinite(*x)) fail(key, "an array of 3 finite numbers");
    v[i] = *x;
  }
  return note(key, v);
}

std::vector<std::string> CaseFile::strings(const std::string& key,
                                           std::optional<std::vector<std::string>> fallback) {
  mark(canonical(split_key(key)));
  const auto* n = find(key);
  if (!n) {
    if (fallback) return note(key, *fallback);
    fail(key, "an array of strings");
  }
  const auto* a = n->as_array();
  if (!a) fail(key, "an array of strings");
  std::vector<std::string> out;
  for (auto&& e : *a) {
    if (!e.is_string()) fail(key, "an array of strings");
    out.push_back(*e.value<std::string>());
  }
  return note(key, out);
}

std::vector<double> CaseFile::numbers(const std::string& key) {
  mark(canonical(split_key(key)));
  const auto* n = find(key);
  const auto* a = n ? n->as_array() : nullptr;
  if (!a) fail(key, "an array of numbers");
  std::vector<double> out;
  for (auto&& e : *a) {
    const auto x = e.value<double>();
    if (!x || !std::isfinite(*x)) fail(key, "an array of finite numbers");
    out.push_back(*x);
  }
  return note(key, out);
}

std::vector<std::array<double, 2>> CaseFile::points(const std::string& key) {
  mark(canonical(split_key(key)));
  const auto* n = find(key);
  const auto* a = n ? n->as_array() : nullptr;
  if (!a) fail(key, "an array of [x, y] points");
  std::vector<std::array<double, 2>> out;
  for (auto&& e : *a) {
    const auto* p = e.as_array();
    if (!p || p->size() != 2) fail(key, "points written as [x, y]");
    auto x = p->get(0)->value<double>(), y = p->get(1)->value<double>();
    if (!x || !y || !std::isfinite(*x) || !std::isfinite(*y)) fail(key, "points of two finite numbers");
    out.push_back({*x, *y});
  }
  return out;
}

std::size_t CaseFile::array_size(const std::string& key) {
  const auto* n = find(key);
  if (!n) return 0;
  const auto* a = n->as_array();
  if (!a || !a->is_array_of_tables()) fail(key, "an array of tables ([[" + key + "]])");
  return a->size();
}

std::vector<std::pair<std::string, std::string>> CaseFile::leaf_values() const {
  std::vector<std::string> leaves, path;
  collect_leaves(table_, path, leaves);
  std::vector<std::pair<std::string, std::string>> out;
  for (const auto& leaf : leaves) {
    std::ostringstream os;
    if (const auto* n = find(leaf)) n->visit([&os](const auto& v) { os << v; });
    out.emplace_back(leaf, os.str());
  }
  return out;
}

void CaseFile::reject_unknown_keys() const {
  std::vector<std::string> leaves, path;
  collect_leaves(table_, path, leaves);
  const std::vector<std::string> known(used_.begin(), used_.end());
  for (const auto& leaf : leaves)
    if (!used_.count(leaf)) {
      const std::string near = closest(leaf, known);
      throw ConfigError(source_ + ": unknown key '" + leaf + "'" +
                        (near.empty() ? "" : " (did you mean '" + near + "'?)") +
                        " (see docs/case-file.md for the keys a case file may use)");
    }
}

}  // namespace cassini
