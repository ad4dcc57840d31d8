/* A timed loop over an FMU's binary as an importer (Simulink, a co-simulation master) calls it:
   fmi3SetFloat64 of the inputs, fmi3DoStep and fmi3GetFloat64 of the residuals per sample, on
   the samples of generator.c. The FMU's value references are given on the command line.

   cc -std=c99 -O2 fmu.c -ldl -lm -o fmu
   fmu LIBRARY.so TOKEN STEP_VR WINDOW_VR "INPUT_VRS" "OUTPUT_VRS" WINDOW PASSES */
#define _POSIX_C_SOURCE 200809L
#include <dlfcn.h>
#include <math.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef void *(*instantiate_fn)(const char *, const char *, const char *, bool, bool, bool, bool,
                                const uint32_t *, size_t, void *, void *, void *);
typedef int (*mode_fn)(void *);
typedef int (*init_fn)(void *, bool, double, double, bool, double);
typedef int (*set_float_fn)(void *, const uint32_t *, size_t, const double *, size_t);
typedef int (*get_float_fn)(void *, const uint32_t *, size_t, double *, size_t);
typedef int (*set_int_fn)(void *, const uint32_t *, size_t, const int32_t *, size_t);
typedef int (*step_fn)(void *, double, double, bool, bool *, bool *, bool *, double *);
typedef void (*free_fn)(void *);

#define SAMPLES 10000

static double shape[SAMPLES][3];

static size_t parse(const char *list, uint32_t *out)
{
    size_t n = 0;
    char *end;
    while (*list != '\0' && n < 64) {
        out[n++] = (uint32_t)strtoul(list, &end, 10);
        list = *end == ',' ? end + 1 : end;
    }
    return n;
}

static void *symbol(void *library, const char *name)
{
    void *f = dlsym(library, name);
    if (f == NULL) {
        fprintf(stderr, "no %s\n", name);
        exit(1);
    }
    return f;
}

int main(int argc, char **argv)
{
    uint32_t inputs[64], outputs[64], noises[64], step_vr, window_vr;
    size_t n_in, n_out, n_noise = 0, k, j;
    int pass, passes;
    int32_t window;
    double h = 1e-3, u[64], y[64], levels[64], sink = 0.0, seconds, at;
    bool flag;
    clock_t start;
    void *library;
    if (argc < 9)
        return 2;
    library = dlopen(argv[1], RTLD_NOW);
    if (library == NULL) {
        fprintf(stderr, "%s\n", dlerror());
        return 1;
    }
    step_vr = (uint32_t)atoi(argv[3]);
    window_vr = (uint32_t)atoi(argv[4]);
    n_in = parse(argv[5], inputs);
    n_out = parse(argv[6], outputs);
    window = atoi(argv[7]);
    passes = atoi(argv[8]);
    /* With a ninth argument, the residuals' noise levels' references: every size runs. */
    if (argc > 9)
        n_noise = parse(argv[9], noises);
    for (k = 0; k < n_noise; k++)
        levels[k] = 0.01;
    {
        instantiate_fn instantiate = (instantiate_fn)symbol(library, "fmi3InstantiateCoSimulation");
        init_fn enter = (init_fn)symbol(library, "fmi3EnterInitializationMode");
        mode_fn exit_init = (mode_fn)symbol(library, "fmi3ExitInitializationMode");
        set_float_fn set = (set_float_fn)symbol(library, "fmi3SetFloat64");
        get_float_fn get = (get_float_fn)symbol(library, "fmi3GetFloat64");
        set_int_fn set_int = (set_int_fn)symbol(library, "fmi3SetInt32");
        step_fn step = (step_fn)symbol(library, "fmi3DoStep");
        free_fn release = (free_fn)symbol(library, "fmi3FreeInstance");
        for (k = 0; k < SAMPLES; k++) {
            shape[k][0] = sin(k * h);
            shape[k][1] = cos(1.3 * k * h);
            shape[k][2] = sin(0.7 * k * h);
        }
        start = clock();
        for (pass = 0; pass < passes; pass++) {
            void *fmu = instantiate("speed", argv[2], "", false, false, false, false, NULL, 0,
                                    NULL, NULL, NULL);
            if (fmu == NULL)
                return 1;
            enter(fmu, false, 0.0, 0.0, false, 0.0);
            set(fmu, &step_vr, 1, &h, 1);
            set_int(fmu, &window_vr, 1, &window, 1);
            if (n_noise > 0)
                set(fmu, noises, n_noise, levels, n_noise);
            if (exit_init(fmu) != 0)
                return 1;
            for (k = 0; k < SAMPLES; k++) {
                for (j = 0; j < n_in; j++)
                    u[j] = shape[k][j % 3];
                set(fmu, inputs, n_in, u, n_in);
                step(fmu, k * h, h, true, &flag, &flag, &flag, &at);
                get(fmu, outputs, n_out, y, n_out);
                sink += y[0] == y[0] ? y[0] : 0.0;
            }
            release(fmu);
        }
        seconds = (double)(clock() - start) / CLOCKS_PER_SEC;
    }
    printf("%.1f ns per sample (window %d, %d passes of %d samples; checksum %g)\n",
           1e9 * seconds / ((double)passes * SAMPLES), (int)window, passes, SAMPLES, sink);
    return 0;
}
