#include "physics/channel/VolumeFraction.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace cassini {

namespace {
constexpr double kFixedPoint = 0x1.0p50;  // phi resolution 1e-15, room for sums up to 8192
}

VolumeFraction::VolumeFraction(const ChannelGeometry& geo, double x0, double x1, double y0, double y1, double height,
                               double width)
    : geo_(geo), x0_(x0), y0_(y0), h_(width / 4), height_(height), width_(width) {
  nx_ = static_cast<int>(std::ceil((x1 - x0) / h_)) + 1;
  ny_ = static_cast<int>(std::ceil((y1 - y0) / h_)) + 1;
  reach_ = 12;  // 3 widths
  fluid_.resize(std::size_t(nx_) * ny_);
  for (int i = 0; i < nx_; ++i)
    for (int j = 0; j < ny_; ++j) fluid_[i * ny_ + j] = geo.inside(x0_ + i * h_, y0_ + j * h_);
  phi_.assign(fluid_.size(), 0.0);
  sum_.assign(fluid_.size(), 0);
  total_ = sum_;
}

template <class F>
void VolumeFraction::for_nodes(double x, double y, F&& f) const {
  const int ci = static_cast<int>(std::lround((x - x0_) / h_)), cj = static_cast<int>(std::lround((y - y0_) / h_));
  const int i0 = std::max(0, ci - reach_), i1 = std::min(nx_ - 1, ci + reach_);
  const int j0 = std::max(0, cj - reach_), j1 = std::min(ny_ - 1, cj + reach_);
  const double inv = 1 / (2 * width_ * width_), cut2 = 9 * width_ * width_;
  // The Gaussian factorises: 2 x 25 exponentials per particle instead of 25 x 25.
  wx_.resize(i1 - i0 + 1);
  wy_.resize(j1 - j0 + 1);
  for (int i = i0; i <= i1; ++i) {
    const double dx = x0_ + i * h_ - x;
    wx_[i - i0] = std::exp(-dx * dx * inv);
  }
  for (int j = j0; j <= j1; ++j) {
    const double dy = y0_ + j * h_ - y;
    wy_[j - j0] = std::exp(-dy * dy * inv);
  }
  scratch_.clear();
  double norm = 0;
  for (int i = i0; i <= i1; ++i) {
    const double dx = x0_ + i * h_ - x;
    for (int j = j0; j <= j1; ++j) {
      const int n = i * ny_ + j;
      if (!fluid_[n]) continue;
      const double dy = y0_ + j * h_ - y;
      if (dx * dx + dy * dy > cut2) continue;
      const double w = wx_[i - i0] * wy_[j - j0];
      scratch_.emplace_back(n, w);
      norm += w;
    }
  }
  if (norm > 0)
    for (const auto& [n, w] : scratch_) f(n, w / norm);
}

void VolumeFraction::update(const ParticleStore& p, MPI_Comm comm) {
  std::fill(sum_.begin(), sum_.end(), 0);
  const double per_area = 1 / (h_ * h_ * height_);
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    const double vol = 4.0 / 3.0 * std::numbers::pi * p.radius[i] * p.radius[i] * p.radius[i];
    for_nodes(p.x[i][0], p.x[i][1],
              [&](int n, double w) {
                // Non-negative and below 2^52: adding 0.5 and truncating is llround, cheaper.
                sum_[n] += static_cast<std::int64_t>(vol * w * per_area * kFixedPoint + 0.5);
              });
  }
  MPI_Allreduce(sum_.data(), total_.data(), static_cast<int>(sum_.size()), MPI_INT64_T, MPI_SUM, comm);
  for (std::size_t n = 0; n < phi_.size(); ++n) phi_[n] = total_[n] / kFixedPoint;
}

double VolumeFraction::at(double x, double y) const {
  double phi;
  sample(phi_, 1, x, y, &phi);
  return phi;
}

void VolumeFraction::sample(const std::vector<double>& field, int channels, double x, double y, double* out) const {
  // Bilinear in the node field, which already is the kernel average: a second kernel mean
  // here would smooth twice (an effective width sqrt(2) w instead of w).
  const double s = (x - x0_) / h_, t = (y - y0_) / h_;
  const int i = std::clamp(static_cast<int>(std::floor(s)), 0, nx_ - 2);
  const int j = std::clamp(static_cast<int>(std::floor(t)), 0, ny_ - 2);
  const double fx = std::clamp(s - i, 0.0, 1.0), fy = std::clamp(t - j, 0.0, 1.0);
  // Only fluid nodes count: nodes inside a wall receive no volume (the deposit is normalised
  // over the fluid nodes), so including them would dilute phi next to the walls.
  std::fill(out, out + channels, 0.0);
  double den = 0;
  auto add = [&](int n, double w) {
    if (!fluid_[n]) return;
    const double* f = &field[std::size_t(n) * channels];
    for (int c = 0; c < channels; ++c) out[c] += w * f[c];
    den += w;
  };
  add(i * ny_ + j, (1 - fx) * (1 - fy));
  add(i * ny_ + j + 1, (1 - fx) * fy);
  add((i + 1) * ny_ + j, fx * (1 - fy));
  add((i + 1) * ny_ + j + 1, fx * fy);
  if (den > 1e-3) {
    for (int c = 0; c < channels; ++c) out[c] /= den;
    return;
  }
  std::fill(out, out + channels, 0.0);  // no fluid node around (x, y), e.g. deep in a corner: the kernel mean
  for_nodes(x, y, [&](int n, double w) {
    for (int c = 0; c < channels; ++c) out[c] += w * field[std::size_t(n) * channels + c];
  });
}

void VolumeFraction::deposit(const ParticleStore& p, const std::vector<double>& values, const std::vector<double>& unit,
                             std::vector<double>& out, MPI_Comm comm) const {
  const std::size_t channels = unit.size();
  deposit_sum_.assign(fluid_.size() * channels, 0);
  deposit_total_.resize(deposit_sum_.size());
  std::vector<double> scale(channels);
  for (std::size_t c = 0; c < channels; ++c) scale[c] = kFixedPoint / unit[c];
  std::vector<std::pair<std::size_t, double>> nonzero;  // a particle's channels that are not 0, scaled
  for (std::size_t i = 0; i < p.nlocal; ++i) {
    nonzero.clear();
    for (std::size_t c = 0; c < channels; ++c)
      if (values[i * channels + c] != 0) nonzero.emplace_back(c, values[i * channels + c] * scale[c]);
    if (nonzero.empty()) continue;
    for_nodes(p.x[i][0], p.x[i][1], [&](int n, double w) {
      for (const auto& [c, v] : nonzero) {
        const double x = v * w;  // rounded half away from zero, as llround, without the call
        deposit_sum_[n * channels + c] += static_cast<std::int64_t>(x + (x < 0 ? -0.5 : 0.5));
      }
    });
  }
  MPI_Allreduce(deposit_sum_.data(), deposit_total_.data(), static_cast<int>(deposit_total_.size()), MPI_INT64_T,
                MPI_SUM, comm);
  out.resize(deposit_total_.size());
  const double per_volume = 1 / (h_ * h_ * height_);
  for (std::size_t k = 0; k < out.size(); ++k)
    out[k] = static_cast<double>(deposit_total_[k]) / scale[k % channels] * per_volume;
}

double VolumeFraction::own(double x, double y, double volume) const {
  const double s = (x - x0_) / h_, t = (y - y0_) / h_;
  const int i = std::clamp(static_cast<int>(std::floor(s)), 0, nx_ - 2);
  const int j = std::clamp(static_cast<int>(std::floor(t)), 0, ny_ - 2);
  const double fx = std::clamp(s - i, 0.0, 1.0), fy = std::clamp(t - j, 0.0, 1.0);
  const int corner[4] = {i * ny_ + j, i * ny_ + j + 1, (i + 1) * ny_ + j, (i + 1) * ny_ + j + 1};
  const double bw[4] = {(1 - fx) * (1 - fy), (1 - fx) * fy, fx * (1 - fy), fx * fy};
  double deposit[4] = {0, 0, 0, 0}, all = 0;
  const double per_area = volume / (h_ * h_ * height_);
  for_nodes(x, y, [&](int n, double w) {
    all += w * per_area;  // for the no-fluid-corner fallback of at(): sum w * (w * per_area)
    for (int k = 0; k < 4; ++k)
      if (n == corner[k]) deposit[k] = w * per_area;
  });
  double num = 0, den = 0;
  for (int k = 0; k < 4; ++k)
    if (fluid_[corner[k]]) { num += bw[k] * deposit[k]; den += bw[k]; }
  if (den > 1e-3) return num / den;
  double mine = 0;
  for_nodes(x, y, [&](int, double w) { mine += w * w * per_area; });
  return mine;
}

double VolumeFraction::integral() const {
  double s = 0;
  for (double v : phi_) s += v;
  return s * h_ * h_ * height_;
}

}  // namespace cassini
