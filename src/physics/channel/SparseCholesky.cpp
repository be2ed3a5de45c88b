#include "physics/channel/SparseCholesky.hpp"

#include <dlfcn.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include <Eigen/SparseCholesky>

namespace cassini {
namespace {

using Factory = SparseCholesky* (*)();

// The module's factory, loaded once per process and never unloaded (its objects' code lives there).
Factory supernodal_factory() {
  static Factory factory = nullptr;
  static std::string error;
  static std::once_flag once;
  std::call_once(once, [] {
    const char* name = "libcassini_cholmod.so";
    std::vector<std::filesystem::path> tried;
    if (const char* dir = std::getenv("CASSINI_MODULE_DIR"); dir && *dir) {
      tried = {std::filesystem::path(dir) / name};  // an installation's (or a test's) choice: only there
    } else {
      std::error_code ec;
      const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec).parent_path();
      // beside the executable (cassini, cassini-cg), one folder up (the tests), the build folder
      if (!ec) tried = {exe / name, exe.parent_path() / name};
      const auto built = std::filesystem::path(CASSINI_MODULE_DIR) / name;
      if (std::find(tried.begin(), tried.end(), built) == tried.end()) tried.push_back(built);
    }
    std::string why;
    for (const auto& path : tried) {
      if (!std::filesystem::exists(path)) continue;
      void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
      if (!handle) { why += std::string("\n  ") + dlerror(); continue; }
      factory = reinterpret_cast<Factory>(dlsym(handle, "cassini_new_supernodal_cholesky_v1"));
      if (factory) return;
      why += "\n  " + path.string() + ": no cassini_new_supernodal_cholesky_v1";
    }
    error = std::string("the Stokes solve needs ") + name + " (SuiteSparse's CHOLMOD, built beside cassini); set CASSINI_MODULE_DIR to the folder that holds it; looked in";
    for (const auto& path : tried) error += "\n  " + path.string();
    error += why;
  });
  if (!factory) throw std::runtime_error(error);
  return factory;
}

}  // namespace

std::unique_ptr<SparseCholesky> make_simplicial_cholesky() { return std::make_unique<EigenCholesky<Eigen::SimplicialLLT<SparseCholesky::Matrix>>>(); }

std::unique_ptr<SparseCholesky> make_supernodal_cholesky() {
  return std::unique_ptr<SparseCholesky>(supernodal_factory()());
}

}  // namespace cassini
