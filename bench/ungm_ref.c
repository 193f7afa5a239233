/* ungm_ref.c -- C reference SIR/bootstrap particle filter for the UNGM, the yardstick of
 * `pfbench bench --c-ref` (scripts/bench_vs_c.sh builds it and runs the bench against it).
 * The loop of a plain bootstrap filter: xoshiro256+ (splitmix64 seeding),
 * Box-Muller normals (double), exp(), log-weights with max subtraction, weighted mean,
 * systematic resampling (two-pointer merge, positions (u+i)*S/N, S = weight sum).
 *
 * build: gcc -O3 -march=native -fopenmp -o ungm_ref ungm_ref.c -lm
 * usage: ungm_ref DATAFILE single N REPS MINTIME      -> per rep: "wall_s_per_run runs cpu_s_per_run" (trial 0 data)
 *        ungm_ref DATAFILE batch  N REPS K THREADS    -> per rep: "wall_s cpu_s" for K trials (OpenMP over trials)
 *        ungm_ref DATAFILE rmse   N K                 -> per trial: RMSE of the filtering mean
 * DATAFILE: int64 K, int64 T, then double X[K][T+1], double Y[K][T+1] (written by pfbench bench)
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#define SQ 3.1622776601683795   /* sqrt(10) */
#define SP0 1.4142135623730951  /* sqrt(2)  */
#define FILTER_BASE_SEED 2000000ULL

typedef struct { uint64_t s[4]; } rng_t;

static inline uint64_t rotl(uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
static inline uint64_t xo_next(rng_t *r) {
    uint64_t *s = r->s;
    const uint64_t res = s[0] + s[3];
    const uint64_t t = s[1] << 17;
    s[2] ^= s[0]; s[3] ^= s[1]; s[1] ^= s[2]; s[0] ^= s[3]; s[2] ^= t;
    s[3] = rotl(s[3], 45);
    return res;
}
static inline double u53(uint64_t r) { return (double)(r >> 11) * 0x1.0p-53; }
static void rng_seed(rng_t *r, uint64_t seed) {
    uint64_t z = seed;
    for (int k = 0; k < 4; k++) {
        z += 0x9E3779B97F4A7C15ULL;
        uint64_t x = z;
        x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ULL;
        x = (x ^ (x >> 27)) * 0x94D049BB133111EBULL;
        r->s[k] = x ^ (x >> 31);
    }
}
static void fill_normal(rng_t *r, double *z, int n) {
    int i = 0;
    for (; i + 1 < n; i += 2) {
        double u1 = 1.0 - u53(xo_next(r));
        double u2 = u53(xo_next(r));
        double rad = sqrt(-2.0 * log(u1)), th = 6.283185307179586 * u2;
        z[i] = rad * cos(th);
        z[i + 1] = rad * sin(th);
    }
    if (i < n) {
        double u1 = 1.0 - u53(xo_next(r));
        double u2 = u53(xo_next(r));
        z[i] = sqrt(-2.0 * log(u1)) * cos(6.283185307179586 * u2);
    }
}

/* one filter run; x, xn, w are caller-provided work buffers of length N */
static void pf(const double *y, int T, int N, uint64_t seed, double *xhat,
               double *restrict x, double *restrict xn, double *restrict w) {
    rng_t r;
    rng_seed(&r, seed);
    fill_normal(&r, x, N);
    for (int i = 0; i < N; i++) x[i] *= SP0;
    xhat[0] = 0.0;
    for (int t = 1; t <= T; t++) {
        const double c = 8.0 * cos(1.2 * t), yt = y[t];
        fill_normal(&r, xn, N);
        double m = -INFINITY;
        for (int i = 0; i < N; i++) {
            double xi = x[i];
            double v = 0.5 * xi + 25.0 * xi / (1.0 + xi * xi) + c + SQ * xn[i];
            xn[i] = v;
            double d = yt - v * v / 20.0;
            double lw = -0.5 * d * d;
            w[i] = lw;
            m = lw > m ? lw : m;
        }
        double s = 0.0, sx = 0.0;
        for (int i = 0; i < N; i++) {
            double e = exp(w[i] - m);
            w[i] = e;
            s += e;
            sx += e * xn[i];
        }
        xhat[t] = sx / s;
        const double step = s / N, u = u53(xo_next(&r));
        int j = 0;
        double cum = w[0];
        for (int i = 0; i < N; i++) {
            double pos = (u + i) * step;
            while (pos >= cum && j < N - 1) { j++; cum += w[j]; }
            x[i] = xn[j];
        }
    }
}

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}
static double cpu_now(void) { /* CPU time of the whole process (all threads) */
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

int main(int argc, char **argv) {
    if (argc < 5) { fprintf(stderr, "see header for usage\n"); return 2; }
    FILE *fh = fopen(argv[1], "rb");
    if (!fh) { perror("data"); return 1; }
    int64_t hdr[2];
    if (fread(hdr, 8, 2, fh) != 2) return 1;
    const int K0 = (int)hdr[0], T = (int)hdr[1], T1 = T + 1;
    double *X = malloc(sizeof(double) * K0 * T1), *Y = malloc(sizeof(double) * K0 * T1);
    if (fread(X, sizeof(double), (size_t)K0 * T1, fh) != (size_t)K0 * T1) return 1;
    if (fread(Y, sizeof(double), (size_t)K0 * T1, fh) != (size_t)K0 * T1) return 1;
    fclose(fh);
    const char *mode = argv[2];
    const int N = atoi(argv[3]);

    if (!strcmp(mode, "single")) {
        int reps = atoi(argv[4]);
        double mintime = argc > 5 ? atof(argv[5]) : 0.2;
        double *xhat = malloc(sizeof(double) * T1);
        double *x = malloc(sizeof(double) * N), *xn = malloc(sizeof(double) * N), *w = malloc(sizeof(double) * N);
        pf(Y, T, N, 1, xhat, x, xn, w); /* warm-up (page faults, caches) */
        for (int rep = 0; rep < reps; rep++) {
            long cnt = 0;
            double t0 = now(), c0 = cpu_now(), el;
            do { pf(Y, T, N, FILTER_BASE_SEED + rep * 7919 + cnt, xhat, x, xn, w); cnt++; el = now() - t0; } while (el < mintime);
            printf("%.9g %ld %.9g\n", el / cnt, cnt, (cpu_now() - c0) / cnt);
        }
    } else if (!strcmp(mode, "batch")) {
        int reps = atoi(argv[4]), K = atoi(argv[5]), th = argc > 6 ? atoi(argv[6]) : 1;
        if (K > K0) K = K0;
#ifdef _OPENMP
        omp_set_num_threads(th);
#endif
        double *XH = malloc(sizeof(double) * K * T1);
        for (int rep = -1; rep < reps; rep++) { /* rep -1 = warm-up */
            double t0 = now(), c0 = cpu_now();
#pragma omp parallel
            {
                double *x = malloc(sizeof(double) * N), *xn = malloc(sizeof(double) * N), *w = malloc(sizeof(double) * N);
#pragma omp for schedule(static)
                for (int k = 0; k < K; k++) pf(Y + (size_t)k * T1, T, N, FILTER_BASE_SEED + k, XH + (size_t)k * T1, x, xn, w);
                free(x); free(xn); free(w);
            }
            double el = now() - t0;
            if (rep >= 0) printf("%.9g %.9g\n", el, cpu_now() - c0);
        }
    } else if (!strcmp(mode, "rmse")) {
        int K = atoi(argv[4]);
        if (K > K0) K = K0;
        double *xhat = malloc(sizeof(double) * T1);
        double *x = malloc(sizeof(double) * N), *xn = malloc(sizeof(double) * N), *w = malloc(sizeof(double) * N);
        for (int k = 0; k < K; k++) {
            pf(Y + (size_t)k * T1, T, N, FILTER_BASE_SEED + k, xhat, x, xn, w);
            double se = 0.0;
            for (int t = 1; t <= T; t++) { double d = xhat[t] - X[(size_t)k * T1 + t]; se += d * d; }
            printf("%.12g\n", sqrt(se / T));
        }
    } else { fprintf(stderr, "bad mode\n"); return 2; }
    return 0;
}
