/* A timed loop over a model's C residual generator (`bgc MODEL --emit c -o m.c`): 10,000 raw
   samples 1 ms apart, [sin t, cos 1.3t, sin 0.7t, ...] as the Rust criterion bench of the
   bench's generator takes them (crates/bondgraph/benches/residuals.rs), pushed PASSES times
   through a fresh generator; prints the nanoseconds per sample.

   cc -std=c99 -O2 -DBGC_HEADER='"m.h"' -DBGC_PREFIX=model -DBGC_UPPER=MODEL m.c generator.c -lm
   generator WINDOW PASSES */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include BGC_HEADER

#define JOIN2(a, b) a##_##b
#define JOIN(a, b) JOIN2(a, b)
#define F(name) JOIN(BGC_PREFIX, name)
#define M(name) JOIN(BGC_UPPER, name)

#define SAMPLES 10000
#define WIDTH (M(RAW) > 0 ? M(RAW) : 1)

static F(generator) generator;
static double raw[SAMPLES][WIDTH];

int main(int argc, char **argv)
{
    int window = argc > 1 ? atoi(argv[1]) : 11, passes = argc > 2 ? atoi(argv[2]) : 200;
    int degree = M(ORDER) > 3 ? M(ORDER) : 3, k, j, pass;
    double h = 1e-3, sink = 0.0, seconds;
    F(output) out;
    clock_t start;
    for (k = 0; k < SAMPLES; k++) {
        double t = k * h, shape[3];
        shape[0] = sin(t);
        shape[1] = cos(1.3 * t);
        shape[2] = sin(0.7 * t);
        for (j = 0; j < M(RAW); j++)
            raw[k][j] = shape[j % 3];
    }
    start = clock();
    for (pass = 0; pass < passes; pass++) {
        if (F(init)(&generator, &F(default_params), h, window, degree) != BGC_OK)
            return 1;
        for (k = 0; k < SAMPLES; k++)
            if (F(push)(&generator, k * h, raw[k], &out))
                sink += out.residuals[0];
    }
    seconds = (double)(clock() - start) / CLOCKS_PER_SEC;
    printf("%.1f ns per sample (window %d, %d passes of %d samples; checksum %g)\n",
           1e9 * seconds / ((double)passes * SAMPLES), window, passes, SAMPLES, sink);
    return 0;
}
