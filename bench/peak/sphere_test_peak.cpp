// The machine's measured peak for the demo's inner kernel: ray-sphere tests per second when
// nothing else is in the way — rays and spheres in flat arrays, no branches, the loop
// vectorised for this CPU (-march=native), every core busy. bench_performance.py reports the
// demo's own tests/s as a fraction of this.
// Usage: sphere_test_peak [THREADS]   prints "tests_per_second N"
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include <vector>

namespace {

constexpr int kRays = 4096;  // fits in L1/L2 with the spheres: compute-bound, as the demo is
constexpr int kSpheres = 8;  // the paper scene's count
constexpr int kRounds = 400;

// One ray against one sphere as the paper tests it (geometric form), branch-free: the
// nearest positive root, or +inf on a miss.
inline float hit_t(float ox, float oy, float oz, float dx, float dy, float dz, float cx, float cy,
                   float cz, float r2) {
    const float lx = cx - ox, ly = cy - oy, lz = cz - oz;
    const float tca = lx * dx + ly * dy + lz * dz;
    const float d2 = lx * lx + ly * ly + lz * lz - tca * tca;
    const float disc = r2 - d2;
    const float thc = std::sqrt(disc > 0 ? disc : 0.0f);
    const float t0 = tca - thc;
    const float t = t0 < 0 ? tca + thc : t0;
    return (tca >= 0 && d2 <= r2) ? t : INFINITY;
}

double run(unsigned seed, double* sink) {
    std::vector<float> ox(kRays), oy(kRays), oz(kRays), dx(kRays), dy(kRays), dz(kRays),
        best(kRays);
    std::srand(seed);
    auto u = [] { return static_cast<float>(std::rand()) / RAND_MAX - 0.5f; };
    for (int i = 0; i < kRays; ++i) {
        ox[i] = u();
        oy[i] = u();
        oz[i] = u();
        float x = u(), y = u(), z = -1.0f, l = std::sqrt(x * x + y * y + z * z);
        dx[i] = x / l;
        dy[i] = y / l;
        dz[i] = z / l;
    }
    float cx[kSpheres], cy[kSpheres], cz[kSpheres], r2[kSpheres];
    for (int s = 0; s < kSpheres; ++s) {
        cx[s] = u() * 8;
        cy[s] = u() * 8;
        cz[s] = -10 - s;
        r2[s] = 1 + s;
    }
    const auto start = std::chrono::steady_clock::now();
    for (int round = 0; round < kRounds; ++round) {
        for (int i = 0; i < kRays; ++i) best[i] = INFINITY;
        for (int s = 0; s < kSpheres; ++s)
            for (int i = 0; i < kRays; ++i) {
                const float t =
                    hit_t(ox[i], oy[i], oz[i], dx[i], dy[i], dz[i], cx[s], cy[s], cz[s], r2[s]);
                best[i] = t < best[i] ? t : best[i];
            }
        ox[round % kRays] += best[(round * 7) % kRays] * 1e-9f;  // keep the rounds dependent
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    double sum = 0;
    for (float b : best) sum += std::isfinite(b) ? b : 0;
    *sink = sum;
    return seconds;
}

}  // namespace

int main(int argc, char** argv) {
    const int threads =
        argc > 1 ? std::atoi(argv[1]) : static_cast<int>(std::thread::hardware_concurrency());
    if (threads < 1) {
        std::fprintf(stderr, "usage: sphere_test_peak [THREADS >= 1]\n");
        return 2;
    }
    double best = 0;
    for (int trial = 0; trial < 3; ++trial) {  // best of 3: the peak, not the average
        std::vector<double> seconds(threads), sinks(threads);
        std::vector<std::thread> pool;
        for (int t = 0; t < threads; ++t)
            pool.emplace_back([&, t] { seconds[t] = run(1 + t, &sinks[t]); });
        for (auto& t : pool) t.join();
        double slowest = 0;
        for (double s : seconds) slowest = std::fmax(slowest, s);
        best = std::fmax(best, double(threads) * kRounds * kRays * kSpheres / slowest);
    }
    std::printf("tests_per_second %.6g\n", best);
    return 0;
}
