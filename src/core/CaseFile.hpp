#pragma once
// Reading a TOML case file with errors a user can act on: every failure names the file,
// the key and what was expected. Keys are tracked as they are read, so that any key the
// solver never looked at is reported as unknown instead of being silently ignored.
#include <array>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include <toml++/toml.h>

#include "core/Vec3.hpp"

namespace cassini {

struct ConfigError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class CaseFile {
 public:
  // `source` is the file the text came from (for messages); overrides are "a.b=v" strings.
  static CaseFile parse(const std::string& text, const std::string& source,
                        const std::vector<std::string>& overrides = {});
  static CaseFile load(const std::string& path, const std::vector<std::string>& overrides = {});

  bool has(const std::string& key) const;
  double number(const std::string& key, std::optional<double> fallback = std::nullopt);
  double positive(const std::string& key, std::optional<double> fallback = std::nullopt);  // > 0
  double non_negative(const std::string& key, std::optional<double> fallback = std::nullopt);  // >= 0
  long integer(const std::string& key, std::optional<long> fallback = std::nullopt);
  bool boolean(const std::string& key, std::optional<bool> fallback = std::nullopt);
  std::string string(const std::string& key, std::optional<std::string> fallback = std::nullopt);
  Vec3 vec3(const std::string& key, std::optional<Vec3> fallback = std::nullopt);
  std::vector<std::string> strings(const std::string& key,
                                   std::optional<std::vector<std::string>> fallback = std::nullopt);
  std::vector<double> numbers(const std::string& key);  // an array of finite numbers
  // An array of [x, y] pairs (a polyline).
  std::vector<std::array<double, 2>> points(const std::string& key);
  std::size_t array_size(const std::string& key);  // number of entries of an array of tables

  // Every value read so far, defaults included, by key ("species[0].radius" -> "0.0005"):
  // what the run resolved, whatever the spelling. record() adds a derived value under the key
  // it stands for (dt from time.n_c) and forget() drops the key it came from.
  const std::map<std::string, std::string>& resolved() const { return resolved_; }
  void record(const std::string& key, double value);
  void forget(const std::string& key);

  // Every leaf key of the file ("species[0].radius") with its value as TOML text.
  std::vector<std::pair<std::string, std::string>> leaf_values() const;

  // Throws ConfigError for the first key in the file that was never read.
  void reject_unknown_keys() const;
  [[noreturn]] void fail(const std::string& key, const std::string& expected) const;

  const std::string& source() const { return source_; }
  const toml::table& table() const { return table_; }
  std::string directory() const;  // directory of the case file, for relative paths

 private:
  const toml::node* find(const std::string& key) const;
  void mark(const std::string& key) { used_.insert(key); }

  toml::table table_;
  std::string source_;
  std::set<std::string> used_;
  std::map<std::string, std::string> resolved_;
  template <class T>
  T note(const std::string& key, T value);  // records value as resolved, returns it
};

}  // namespace cassini
