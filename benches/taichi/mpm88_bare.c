/* mpm88 as a bare C kernel: what this machine allows for the algorithm of Taichi's 88-line
 * MLS-MPM example (taichi/examples/simulation/mpm88.py, Hu et al., ACM TOG 37(4), 2018), with
 * no framework around it. The same computation as benches/taichi/mpm88.py: collocated 128²
 * nodes, dx = 1/128, dt = 2e-4, p_vol = (dx/2)², rho = 1, E = 400, gravity 9.8, quadratic
 * B-spline APIC, J *= 1 + dt tr C, mpm88's walls (grid velocity into a wall zeroed on nodes
 * i < 3, i > 125), f32, 2,000 steps, from the same 2 × 2-per-cell lattice in
 * [0.2, 0.7] × [0.2, 0.45] (8,192 points, velocity (0, −1), J = 1, C = 0).
 *
 * Plain C: points as structure of arrays, the grid as (vx, vy, m, pad) per node; the
 * grid-to-particles pass runs 8 points at once with AVX2 gathers when the compiler targets
 * AVX2 (-march=native here), the scalar loop otherwise (same results to f32 rounding). A
 * masked AVX-512 add of each stencil row in particles-to-grid was tried and was slower.
 *
 * Prints the best of --repeat runs (default 3) of all the steps, as particle-steps per
 * second (8,192 × steps / seconds), and a physics checksum every 500 steps: the kinetic
 * energy Σ ½ m v² and the points' mean height, to compare with
 * `mpm88.py --threads 1 --history FILE` (its rows at the same steps).
 *
 * One thread:
 *   gcc -O3 -march=native -o /tmp/mpm88_bare benches/taichi/mpm88_bare.c -lm
 *   /tmp/mpm88_bare --repeat 3
 * N threads (OpenMP; each thread scatters its points into its own grid, the grids are then
 * summed node by node, which also zeroes them for the next step; two barriers a step):
 *   gcc -O3 -march=native -fopenmp -o /tmp/mpm88_bare_omp benches/taichi/mpm88_bare.c -lm
 *   GOMP_SPINCOUNT=10000 /tmp/mpm88_bare_omp --threads 2 --repeat 3
 * (a thread waiting at a barrier spins 10,000 times, then sleeps. libgomp's default spins
 * 300,000 times: on the shared machine at load 3 a spinning thread took the core its
 * partner needed and the run was 5× slower; never spinning, OMP_WAIT_POLICY=passive, was
 * 30 % slower than GOMP_SPINCOUNT=10000 at load 1.1, 48.7 against 69.2 M particle-steps/s.)
 * benches/taichi/compare.py compiles and runs both. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#ifdef __AVX2__
#include <immintrin.h>
#endif
#ifdef _OPENMP
#include <omp.h>
#endif

#define NG 128
#define NN (NG * NG)
#define NPMAX 16384
#define MAXT 64

static const float dx = 1.0f / NG, inv_dx = (float)NG, dt = 2e-4f;
static const float p_vol = (0.5f / NG) * (0.5f / NG), p_rho = 1.0f, gravity = 9.8f, E = 400.0f;
static const int bound = 3;

typedef struct { float vx, vy, m, pad; } Node;

static int n;
/* points, structure of arrays (x0 = x, x1 = y; C row-major) */
static float x0[NPMAX], x1[NPMAX], v0[NPMAX], v1[NPMAX], C00[NPMAX], C01[NPMAX], C10[NPMAX], C11[NPMAX], J[NPMAX];
static Node *priv[MAXT]; /* per-thread scatter grids */
static Node grid[NN];    /* the summed grid */

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

static inline float sq(float a) { return a * a; }

/* quadratic B-spline of a point at x along one axis: base node b, fraction f from it, weights w */
static inline void weights(float x, int *b, float *f, float w[3]) {
    float X = x * inv_dx;
    *b = (int)(X - 0.5f);
    *f = X - *b;
    w[0] = 0.5f * sq(1.5f - *f);
    w[1] = 0.75f - sq(*f - 1.0f);
    w[2] = 0.5f * sq(*f - 0.5f);
}

/* the lattice benches/taichi/mpm88.py seeds (its `lattice(0)`), in the same order */
static void init(void) {
    double c[2 * NG];
    for (int i = 0; i < NG; i++)
        for (int a = 0; a < 2; a++) c[2 * i + a] = (i + (a + 0.5) / 2) * (1.0 / NG);
    n = 0;
    for (int jy = 0; jy < 2 * NG; jy++) {
        if (c[jy] < 0.2 || c[jy] > 0.45) continue;
        for (int ix = 0; ix < 2 * NG; ix++) {
            if (c[ix] < 0.2 || c[ix] > 0.7) continue;
            x0[n] = (float)c[ix];
            x1[n] = (float)c[jy];
            v0[n] = 0.0f;
            v1[n] = -1.0f;
            C00[n] = C01[n] = C10[n] = C11[n] = 0.0f;
            J[n] = 1.0f;
            n++;
        }
    }
}

/* particles to grid: points [p0, p1) into g */
static void p2g(Node *restrict g, int p0, int p1) {
    for (int p = p0; p < p1; p++) {
        int b0, b1;
        float f0, f1, w0[3], w1[3];
        weights(x0[p], &b0, &f0, w0);
        weights(x1[p], &b1, &f1, w1);
        float stress = -dt * 4.0f * E * p_vol * (J[p] - 1.0f) * inv_dx * inv_dx;
        const float p_mass = p_vol * p_rho;
        float a00 = stress + p_mass * C00[p], a01 = p_mass * C01[p];
        float a10 = p_mass * C10[p], a11 = stress + p_mass * C11[p];
        float mv0 = p_mass * v0[p], mv1 = p_mass * v1[p];
        for (int i = 0; i < 3; i++) {
            float d0 = (i - f0) * dx;
            Node *row = g + (b0 + i) * NG + b1;
            for (int j = 0; j < 3; j++) {
                float d1 = (j - f1) * dx;
                float w = w0[i] * w1[j];
                row[j].vx += w * (mv0 + a00 * d0 + a01 * d1);
                row[j].vy += w * (mv1 + a10 * d0 + a11 * d1);
                row[j].m += w * p_mass;
            }
        }
    }
}

/* grid update of nodes [k0, k1) of the summed grid */
static void grid_op(int k0, int k1) {
    for (int k = k0; k < k1; k++) {
        int i = k / NG, j = k % NG;
        Node *g = &grid[k];
        if (g->m > 0) {
            g->vx /= g->m;
            g->vy /= g->m;
        }
        g->vy -= dt * gravity;
        if (i < bound && g->vx < 0) g->vx = 0;
        if (i > NG - bound && g->vx > 0) g->vx = 0;
        if (j < bound && g->vy < 0) g->vy = 0;
        if (j > NG - bound && g->vy > 0) g->vy = 0;
    }
}

#ifdef __AVX2__
/* grid to particles for 8 points at once: [p, p + 8) (AVX2 gathers of the grid) */
static void g2p8(int p) {
    const __m256 h = _mm256_set1_ps(0.5f), one = _mm256_set1_ps(1.0f), th = _mm256_set1_ps(1.5f);
    const __m256 q = _mm256_set1_ps(0.75f), idx = _mm256_set1_ps(inv_dx), vdx = _mm256_set1_ps(dx);
    const __m256 vdt = _mm256_set1_ps(dt), four = _mm256_set1_ps(4.0f * inv_dx * inv_dx);
    __m256 X0 = _mm256_mul_ps(_mm256_loadu_ps(x0 + p), idx), X1 = _mm256_mul_ps(_mm256_loadu_ps(x1 + p), idx);
    __m256i b0 = _mm256_cvttps_epi32(_mm256_sub_ps(X0, h)), b1 = _mm256_cvttps_epi32(_mm256_sub_ps(X1, h));
    __m256 f0 = _mm256_sub_ps(X0, _mm256_cvtepi32_ps(b0)), f1 = _mm256_sub_ps(X1, _mm256_cvtepi32_ps(b1));
    __m256 w0[3], w1[3], d0[3], d1[3];
    __m256 t;
    t = _mm256_sub_ps(th, f0); w0[0] = _mm256_mul_ps(h, _mm256_mul_ps(t, t));
    t = _mm256_sub_ps(f0, one); w0[1] = _mm256_sub_ps(q, _mm256_mul_ps(t, t));
    t = _mm256_sub_ps(f0, h); w0[2] = _mm256_mul_ps(h, _mm256_mul_ps(t, t));
    t = _mm256_sub_ps(th, f1); w1[0] = _mm256_mul_ps(h, _mm256_mul_ps(t, t));
    t = _mm256_sub_ps(f1, one); w1[1] = _mm256_sub_ps(q, _mm256_mul_ps(t, t));
    t = _mm256_sub_ps(f1, h); w1[2] = _mm256_mul_ps(h, _mm256_mul_ps(t, t));
    for (int i = 0; i < 3; i++) {
        d0[i] = _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps((float)i), f0), vdx);
        d1[i] = _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps((float)i), f1), vdx);
    }
    /* node (b0 + i, b1 + j) at float offset 4 ((b0 + i) NG + b1 + j) of the grid */
    __m256i base = _mm256_slli_epi32(_mm256_add_epi32(_mm256_mullo_epi32(b0, _mm256_set1_epi32(NG)), b1), 2);
    __m256 nv0 = _mm256_setzero_ps(), nv1 = nv0, c00 = nv0, c01 = nv0, c10 = nv0, c11 = nv0;
    const float *g = (const float *)grid;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            __m256i k = _mm256_add_epi32(base, _mm256_set1_epi32(4 * (i * NG + j)));
            __m256 gx = _mm256_i32gather_ps(g, k, 4), gy = _mm256_i32gather_ps(g + 1, k, 4);
            __m256 w = _mm256_mul_ps(w0[i], w1[j]);
            nv0 = _mm256_fmadd_ps(w, gx, nv0);
            nv1 = _mm256_fmadd_ps(w, gy, nv1);
            __m256 s = _mm256_mul_ps(four, w), sx = _mm256_mul_ps(s, gx), sy = _mm256_mul_ps(s, gy);
            c00 = _mm256_fmadd_ps(sx, d0[i], c00);
            c01 = _mm256_fmadd_ps(sx, d1[j], c01);
            c10 = _mm256_fmadd_ps(sy, d0[i], c10);
            c11 = _mm256_fmadd_ps(sy, d1[j], c11);
        }
    _mm256_storeu_ps(v0 + p, nv0);
    _mm256_storeu_ps(v1 + p, nv1);
    _mm256_storeu_ps(x0 + p, _mm256_fmadd_ps(vdt, nv0, _mm256_loadu_ps(x0 + p)));
    _mm256_storeu_ps(x1 + p, _mm256_fmadd_ps(vdt, nv1, _mm256_loadu_ps(x1 + p)));
    __m256 jf = _mm256_fmadd_ps(vdt, _mm256_add_ps(c00, c11), one);
    _mm256_storeu_ps(J + p, _mm256_mul_ps(_mm256_loadu_ps(J + p), jf));
    _mm256_storeu_ps(C00 + p, c00);
    _mm256_storeu_ps(C01 + p, c01);
    _mm256_storeu_ps(C10 + p, c10);
    _mm256_storeu_ps(C11 + p, c11);
}
#endif

/* grid to particles: points [p0, p1) */
static void g2p(int p0, int p1) {
#ifdef __AVX2__
    for (; p0 + 8 <= p1; p0 += 8) g2p8(p0);
#endif
    for (int p = p0; p < p1; p++) {
        int b0, b1;
        float f0, f1, w0[3], w1[3];
        weights(x0[p], &b0, &f0, w0);
        weights(x1[p], &b1, &f1, w1);
        float nv0 = 0, nv1 = 0, c00 = 0, c01 = 0, c10 = 0, c11 = 0;
        for (int i = 0; i < 3; i++) {
            float d0 = (i - f0) * dx;
            const Node *row = grid + (b0 + i) * NG + b1;
            for (int j = 0; j < 3; j++) {
                float d1 = (j - f1) * dx;
                float w = w0[i] * w1[j];
                float gx = row[j].vx, gy = row[j].vy;
                nv0 += w * gx;
                nv1 += w * gy;
                float s = 4.0f * w * inv_dx * inv_dx;
                c00 += s * gx * d0;
                c01 += s * gx * d1;
                c10 += s * gy * d0;
                c11 += s * gy * d1;
            }
        }
        v0[p] = nv0;
        v1[p] = nv1;
        x0[p] += dt * nv0;
        x1[p] += dt * nv1;
        J[p] *= 1.0f + dt * (c00 + c11);
        C00[p] = c00;
        C01[p] = c01;
        C10[p] = c10;
        C11[p] = c11;
    }
}

static void steps(int count, int nt) {
    if (nt == 1) {
        for (int s = 0; s < count; s++) {
            memset(grid, 0, sizeof grid);
            p2g(grid, 0, n);
            grid_op(0, NN);
            g2p(0, n);
        }
        return;
    }
#ifdef _OPENMP
    /* two barriers a step: a thread's grid-to-particles of one step and particles-to-grid
     * of the next are one pass over its points */
#pragma omp parallel num_threads(nt)
    {
        int t = omp_get_thread_num(), T = omp_get_num_threads();
        int p0 = (int)((long)n * t / T), p1 = (int)((long)n * (t + 1) / T);
        int k0 = (int)((long)NN * t / T), k1 = (int)((long)NN * (t + 1) / T);
        p2g(priv[t], p0, p1);
        for (int s = 0; s < count; s++) {
#pragma omp barrier
            /* sum the private grids over this thread's nodes, zeroing them for the next step */
            for (int k = k0; k < k1; k++) {
                Node a = {0, 0, 0, 0};
                for (int u = 0; u < T; u++) {
                    a.vx += priv[u][k].vx;
                    a.vy += priv[u][k].vy;
                    a.m += priv[u][k].m;
                    priv[u][k] = (Node){0, 0, 0, 0};
                }
                grid[k] = a;
            }
            grid_op(k0, k1);
#pragma omp barrier
            for (int q = p0; q < p1; q += 64) {
                int q1 = q + 64 < p1 ? q + 64 : p1;
                g2p(q, q1);
                if (s + 1 < count) p2g(priv[t], q, q1);
            }
        }
    }
#endif
}

static void checksum(int step) {
    double ke = 0, y = 0;
    for (int p = 0; p < n; p++) {
        ke += 0.5 * (double)(p_vol * p_rho) * ((double)v0[p] * v0[p] + (double)v1[p] * v1[p]);
        y += x1[p];
    }
    printf("checksum step %d kinetic_energy %.6e mean_y %.6e\n", step, ke, y / n);
}

int main(int argc, char **argv) {
    int nt = 1, repeat = 3, total = 2000, every = 500;
    for (int a = 1; a + 1 < argc; a += 2) {
        if (!strcmp(argv[a], "--threads")) nt = atoi(argv[a + 1]);
        else if (!strcmp(argv[a], "--repeat")) repeat = atoi(argv[a + 1]);
        else if (!strcmp(argv[a], "--steps")) total = atoi(argv[a + 1]);
        else {
            fprintf(stderr, "usage: %s [--threads N] [--repeat R] [--steps S]\n", argv[0]);
            return 2;
        }
    }
#ifndef _OPENMP
    if (nt != 1) {
        fprintf(stderr, "built without OpenMP: compile with -fopenmp for --threads %d\n", nt);
        return 2;
    }
#endif
    if (nt < 1 || nt > MAXT) return 2;
    for (int t = 0; t < nt; t++) priv[t] = calloc(NN, sizeof(Node));
    double best = 1e30;
    for (int r = 0; r < repeat; r++) {
        init();
        double seconds = 0;
        for (int s = 0; s < total; s += every) {
            int k = total - s < every ? total - s : every;
            double t0 = now();
            steps(k, nt);
            seconds += now() - t0;
            if (r == 0) checksum(s + k);
        }
        printf("run %d seconds %.4f particle_steps_per_s %.6e\n", r + 1, seconds, (double)n * total / seconds);
        if (seconds < best) best = seconds;
    }
    printf("bare mpm88 points %d grid %d steps %d threads %d seconds %.4f particle_steps_per_s %.6e\n", n, NG,
           total, nt, best, (double)n * total / best);
    return 0;
}
