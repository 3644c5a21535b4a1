/* Memory bandwidth of one core: a dot product and a triad on 32 MiB arrays of doubles,
 * best of 20 passes each (bytes moved / time). docs/performance.md quotes its output.
 *   gcc -O3 -march=native -o /tmp/bandwidth benches/bandwidth.c && /tmp/bandwidth */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

int main(void) {
    const size_t n = (32u << 20) / sizeof(double);
    double *a = malloc(n * sizeof *a), *b = malloc(n * sizeof *b), *c = malloc(n * sizeof *c);
    for (size_t i = 0; i < n; i++) { a[i] = 1.0; b[i] = 2.0; c[i] = 0.5; }
    double best_dot = 1e30, best_triad = 1e30, sink = 0.0;
    for (int r = 0; r < 20; r++) {
        double t0 = now(), s = 0.0;
        for (size_t i = 0; i < n; i++) s += a[i] * b[i];
        double t1 = now();
        for (size_t i = 0; i < n; i++) a[i] = b[i] + 0.5 * c[i];
        double t2 = now();
        sink += s;
        if (t1 - t0 < best_dot) best_dot = t1 - t0;
        if (t2 - t1 < best_triad) best_triad = t2 - t1;
    }
    printf("dot   %.1f GB/s (2 arrays read)\n", 2.0 * n * sizeof(double) / best_dot / 1e9);
    printf("triad %.1f GB/s (2 read, 1 written), %.1f GB/s counting the write-allocate read\n",
           3.0 * n * sizeof(double) / best_triad / 1e9, 4.0 * n * sizeof(double) / best_triad / 1e9);
    return sink == 42.0;
}
