// CUDA peer of pendulum-atlas's GPU engine: classical RK4 on the chain of N rigid segments on a
// shaken cart (docs/model.md), one thread per instance, the O(N) articulated-body recursion of
// src/model/chain.rs (the same as benches/peers/jax_cpu.py's `tuned` variant), N a template
// parameter so that every per-thread array has exactly N entries and the loops unroll.
//
// The model: joint springs and dampers (§2-3), a root spring and damper, the two point bumpers
// of §4 (exact law, "loading" or "kelvin_voigt"), the harmonic cart evaluated from the integer
// step as src/engine/plan.rs `cart_at` does (φ = ((step mod spp) + c)/spp cycles, ẍ0 = −Aω²
// sin 2πφ, c ∈ {0, ½, ½, 1}). No piezo (the peer cases have none). Plain y += inc (no Kahan).
//
// Input (text, written by run_cuda_peer.py from a peer case): "N M S" then per instance one line
//   l m J tip Jh g k k0 b b0 gap kc cc law dt spp aw2 lev_0 .. lev_{N-1} y_0 .. y_{2N}
// Output: one line per instance of the 2N+1 final states, then a line "seconds T" (the median
// of the timed runs, cudaEvent; the host build prints its wall time, which is not a GPU figure).
//
// Build: nvcc -O3 -arch=sm_90 -o rk4_chain rk4_chain.cu        (H100/H200)
//        g++ -O2 -x c++ -DHOST_ONLY -o rk4_chain_host rk4_chain.cu   (model check on a CPU)
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <vector>
#include <algorithm>
#include <string>

#ifdef HOST_ONLY
#define HD
#else
#define HD __host__ __device__
#endif

constexpr int MAXN = 17;

struct Params {  // structure of arrays, instance i at [i] (lev: [j * M + i])
  const double *l, *m, *J, *tip, *Jh, *g, *k, *k0, *b, *b0, *gap, *kc, *cc, *law, *dt, *aw2, *lev;
  const int *spp;
  int M;
};

template <typename R>
HD R bumper(R delta, R rate, R kc, R cc, R law) {
  if (!(delta > R(0))) return R(0);
  R spring = kc * delta;
  if (law == R(0)) return spring + cc * (rate > R(0) ? rate : R(0));
  R f = spring + cc * rate;
  return f > R(0) ? f : R(0);
}

// θ̈ of one instance (chain.rs `generalised_forces` + `solve_accelerations`).
template <int N, typename R>
HD void rates(const R* th, const R* om, R a, const Params& P, int i, R* acc) {
  const R l = P.l[i], m = P.m[i], ll = l * l, hml = R(0.5) * m * l, twol = R(2) * l;
  const R mg = m * P.g[i], k = P.k[i], b = P.b[i];
  R sn[N], cs[N], q[N];
  for (int j = 0; j < N; ++j) { sn[j] = sin(th[j]); cs[j] = cos(th[j]); q[j] = R(0); }
  for (int j = 1; j < N; ++j) {
    R tau = -k * (th[j] - th[j - 1]) - b * (om[j] - om[j - 1]);
    q[j] += tau; q[j - 1] -= tau;
  }
  q[0] += -R(P.k0[i]) * th[0] - R(P.b0[i]) * om[0];
  R x = 0, xd = 0;
  for (int j = 0; j < N; ++j) {
    R lv = P.lev[j * P.M + i];
    x += lv * sn[j]; xd += lv * cs[j] * om[j];
  }
  const R gap = P.gap[i], kc = P.kc[i], cc = P.cc[i], law = P.law[i];
  R fx = bumper<R>(-x - gap, -xd, kc, cc, law) - bumper<R>(x - gap, xd, kc, cc, law);
  for (int j = 0; j < N; ++j) q[j] += fx * R(P.lev[j * P.M + i]) * cs[j];
  // backward sweep: articulated inertia K (2×2) and bias p, tip to pivot
  R kxx = P.tip[i], kxy = 0, kyy = P.tip[i], px = 0, py = P.tip[i] * P.g[i];
  R hx[N], hy[N], inv_d[N], beta[N];
  const R base_d = R(P.J[i]) + m * ll * R(0.25);
  for (int j = N - 1; j >= 0; --j) {
    R si = sn[j], ci = cs[j], w2 = om[j] * om[j], nx = ci, ny = -si;
    R knx = kxx * nx + kxy * ny, kny = kxy * nx + kyy * ny;
    R kux = kxx * si + kxy * ci, kuy = kxy * si + kyy * ci;
    R hxj = hml * nx + l * knx, hyj = hml * ny + l * kny;
    R d = base_d + (j == 0 ? R(P.Jh[i]) : R(0)) + ll * (nx * knx + ny * kny);
    R ex = -(hml * si + l * kux) * w2 + px, ey = -(hml * ci + l * kuy) * w2 + py + mg;
    R b2x = -(hml * si + twol * kux) * w2 + R(2) * px;
    R b2y = -(hml * ci + twol * kuy) * w2 + R(2) * py + mg;
    R bj = -R(0.5) * l * (nx * b2x + ny * b2y) + q[j];
    R id = R(1) / d, hbd = bj * id;
    kxx = m + kxx - hxj * hxj * id; kxy = kxy - hxj * hyj * id; kyy = m + kyy - hyj * hyj * id;
    px = ex + hxj * hbd; py = ey + hyj * hbd;
    hx[j] = hxj; hy[j] = hyj; inv_d[j] = id; beta[j] = bj;
  }
  // forward sweep, pivot (moving with the cart) to tip
  R ax = a, ay = 0;
  for (int j = 0; j < N; ++j) {
    R t = (beta[j] - hx[j] * ax - hy[j] * ay) * inv_d[j];
    acc[j] = t;
    R w2 = om[j] * om[j];
    ax += l * (cs[j] * t - sn[j] * w2);
    ay -= l * (sn[j] * t + cs[j] * w2);
  }
}

template <typename R>
HD R cart(long step, R frac, int spp, R aw2) {
  R ph = R(step % spp);
  return -aw2 * sin(R(6.283185307179586) * ((ph + frac) / R(spp)));
}

// S RK4 steps of instance i; y: its 2N states (v stays 0 without a piezo).
template <int N, typename R>
HD void integrate(R* y, const Params& P, int i, long S) {
  const R dt = P.dt[i], h = R(0.5) * dt, dt6 = dt / R(6), aw2 = P.aw2[i];
  const int spp = P.spp[i];
  R k0[2 * N], k1[2 * N], k2[2 * N], k3[2 * N], t[2 * N];
  for (long s = 0; s < S; ++s) {
    R a0 = cart<R>(s, R(0), spp, aw2), am = cart<R>(s, R(0.5), spp, aw2),
      a1 = cart<R>(s, R(1), spp, aw2);
    for (int j = 0; j < N; ++j) k0[j] = y[N + j];
    rates<N, R>(y, y + N, a0, P, i, k0 + N);
    for (int j = 0; j < 2 * N; ++j) t[j] = y[j] + h * k0[j];
    for (int j = 0; j < N; ++j) k1[j] = t[N + j];
    rates<N, R>(t, t + N, am, P, i, k1 + N);
    for (int j = 0; j < 2 * N; ++j) t[j] = y[j] + h * k1[j];
    for (int j = 0; j < N; ++j) k2[j] = t[N + j];
    rates<N, R>(t, t + N, am, P, i, k2 + N);
    for (int j = 0; j < 2 * N; ++j) t[j] = y[j] + dt * k2[j];
    for (int j = 0; j < N; ++j) k3[j] = t[N + j];
    rates<N, R>(t, t + N, a1, P, i, k3 + N);
    for (int j = 0; j < 2 * N; ++j) y[j] += dt6 * (k0[j] + R(2) * (k1[j] + k2[j]) + k3[j]);
  }
}

#ifndef HOST_ONLY
// State component-major (j * M + i): neighbouring threads read neighbouring words.
template <int N, typename R>
__global__ void kernel(R* ys, Params P, long S) {
  int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= P.M) return;
  R y[2 * N];
  for (int j = 0; j < 2 * N; ++j) y[j] = ys[j * P.M + i];
  integrate<N, R>(y, P, i, S);
  for (int j = 0; j < 2 * N; ++j) ys[j * P.M + i] = y[j];
}
#define CK(x) do { cudaError_t e = (x); if (e != cudaSuccess) { \
  fprintf(stderr, "CUDA: %s at %s:%d\n", cudaGetErrorString(e), __FILE__, __LINE__); exit(1);} } while (0)
#endif

struct Host {
  std::vector<double> cols[17], lev;
  std::vector<int> spp;
  std::vector<double> y0;
};

template <int N, typename R>
int run(const Host& H, int M, long S, int repeats, std::vector<double>& y_out, double& seconds) {
  const int ny = 2 * N;
#ifdef HOST_ONLY
  Params P{H.cols[0].data(), H.cols[1].data(), H.cols[2].data(), H.cols[3].data(),
           H.cols[4].data(), H.cols[5].data(), H.cols[6].data(), H.cols[7].data(),
           H.cols[8].data(), H.cols[9].data(), H.cols[10].data(), H.cols[11].data(),
           H.cols[12].data(), H.cols[13].data(), H.cols[14].data(), H.cols[16].data(),
           H.lev.data(), H.spp.data(), M};
  auto t0 = std::chrono::steady_clock::now();
  y_out.assign(size_t(M) * ny, 0.0);
  for (int i = 0; i < M; ++i) {
    R y[2 * N];
    for (int j = 0; j < ny; ++j) y[j] = R(H.y0[size_t(i) * (ny + 1) + j]);
    integrate<N, R>(y, P, i, S);
    for (int j = 0; j < ny; ++j) y_out[size_t(i) * ny + j] = double(y[j]);
  }
  seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  (void)repeats;
#else
  double* d[17];
  for (int c = 0; c < 17; ++c) {
    CK(cudaMalloc(&d[c], sizeof(double) * M));
    CK(cudaMemcpy(d[c], H.cols[c].data(), sizeof(double) * M, cudaMemcpyHostToDevice));
  }
  double* dlev; int* dspp; R* dy;
  CK(cudaMalloc(&dlev, sizeof(double) * M * N));
  CK(cudaMemcpy(dlev, H.lev.data(), sizeof(double) * M * N, cudaMemcpyHostToDevice));
  CK(cudaMalloc(&dspp, sizeof(int) * M));
  CK(cudaMemcpy(dspp, H.spp.data(), sizeof(int) * M, cudaMemcpyHostToDevice));
  std::vector<R> y(size_t(M) * ny);
  for (int i = 0; i < M; ++i)
    for (int j = 0; j < ny; ++j) y[size_t(j) * M + i] = R(H.y0[size_t(i) * (ny + 1) + j]);
  CK(cudaMalloc(&dy, sizeof(R) * y.size()));
  Params P{d[0], d[1], d[2], d[3], d[4], d[5], d[6], d[7], d[8], d[9], d[10], d[11], d[12],
           d[13], d[14], d[16], dlev, dspp, M};
  const int block = 128, grid = (M + block - 1) / block;
  cudaEvent_t e0, e1;
  CK(cudaEventCreate(&e0)); CK(cudaEventCreate(&e1));
  std::vector<double> times;
  for (int r = 0; r <= repeats; ++r) {  // run 0 is the warm-up
    CK(cudaMemcpy(dy, y.data(), sizeof(R) * y.size(), cudaMemcpyHostToDevice));
    CK(cudaEventRecord(e0));
    kernel<N, R><<<grid, block>>>(dy, P, S);
    CK(cudaGetLastError());
    CK(cudaEventRecord(e1));
    CK(cudaEventSynchronize(e1));
    float ms; CK(cudaEventElapsedTime(&ms, e0, e1));
    if (r > 0) times.push_back(ms * 1e-3);
  }
  std::vector<R> out(y.size());
  CK(cudaMemcpy(out.data(), dy, sizeof(R) * y.size(), cudaMemcpyDeviceToHost));
  y_out.assign(size_t(M) * ny, 0.0);
  for (int i = 0; i < M; ++i)
    for (int j = 0; j < ny; ++j) y_out[size_t(i) * ny + j] = double(out[size_t(j) * M + i]);
  std::sort(times.begin(), times.end());
  seconds = times[times.size() / 2];
#endif
  return 0;
}

template <typename R>
int dispatch(int n, const Host& H, int M, long S, int rep, std::vector<double>& y, double& s) {
  switch (n) {
    case 3: return run<3, R>(H, M, S, rep, y, s);
    case 9: return run<9, R>(H, M, S, rep, y, s);
    case 17: return run<17, R>(H, M, S, rep, y, s);
    default: fprintf(stderr, "N = %d: this peer is built for N = 3, 9, 17\n", n); return 2;
  }
}

int main(int argc, char** argv) {
  if (argc < 3) {
    fprintf(stderr, "usage: rk4_chain INPUT f32|f64 [repeats]\n");
    return 2;
  }
  FILE* f = fopen(argv[1], "r");
  if (!f) { perror(argv[1]); return 2; }
  const bool f64 = std::string(argv[2]) == "f64";
  const int repeats = argc > 3 ? atoi(argv[3]) : 3;
  int n, M; long S;
  if (fscanf(f, "%d %d %ld", &n, &M, &S) != 3 || n < 1 || n > MAXN || M < 1 || S < 0) {
    fprintf(stderr, "%s: bad header (N in 1..%d, M >= 1, S >= 0)\n", argv[1], MAXN);
    return 2;
  }
  Host H;
  for (auto& c : H.cols) c.resize(M);
  H.lev.resize(size_t(M) * n);
  H.spp.resize(M);
  H.y0.resize(size_t(M) * (2 * n + 1));
  for (int i = 0; i < M; ++i) {
    // l m J tip Jh g k k0 b b0 gap kc cc law dt spp aw2 | lev[N] | y[2N+1]
    for (int c = 0; c < 15; ++c)
      if (fscanf(f, "%lf", &H.cols[c][i]) != 1) { fprintf(stderr, "bad instance %d\n", i); return 2; }
    double spp;
    if (fscanf(f, "%lf %lf", &spp, &H.cols[16][i]) != 2) { fprintf(stderr, "bad instance %d\n", i); return 2; }
    H.spp[i] = int(spp);
    for (int j = 0; j < n; ++j)
      if (fscanf(f, "%lf", &H.lev[size_t(j) * M + i]) != 1) { fprintf(stderr, "bad levers %d\n", i); return 2; }
    for (int j = 0; j < 2 * n + 1; ++j)
      if (fscanf(f, "%lf", &H.y0[size_t(i) * (2 * n + 1) + j]) != 1) { fprintf(stderr, "bad y0 %d\n", i); return 2; }
  }
  fclose(f);
  std::vector<double> y;
  double seconds = 0;
  int rc = f64 ? dispatch<double>(n, H, M, S, repeats, y, seconds)
               : dispatch<float>(n, H, M, S, repeats, y, seconds);
  if (rc) return rc;
  for (int i = 0; i < M; ++i) {
    for (int j = 0; j < 2 * n; ++j) printf("%.17g ", y[size_t(i) * 2 * n + j]);
    printf("0\n");
  }
  printf("seconds %.9g\n", seconds);
  return 0;
}
