/* Runs a model's C residual generator (`bgc MODEL --emit c -o m.c`) over a CSV record and
   prints what `bgc residuals` prints of it: per estimate t, the residuals, their thresholds,
   the alarms and the candidates; with sizes, each sized parameter's estimate after the
   sample (value, half-width, misfit).

   cc -std=c99 -DBGC_HEADER='"m.h"' -DBGC_PREFIX=model -DBGC_UPPER=MODEL m.c replay.c -lm
   replay RECORD.csv STEP WINDOW [--debounce N] [--adaptive] [--integration N|start]
          [--threshold K=LEVEL]... [--noise RMS1,RMS2...] [--memory N]
          [--size PARAMETER]... [--sizes N: the first N the residuals read] */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include BGC_HEADER

#define JOIN2(a, b) a##_##b
#define JOIN(a, b) JOIN2(a, b)
#define F(name) JOIN(BGC_PREFIX, name)
#define M(name) JOIN(BGC_UPPER, name)

#define LINE 65536
#define COLUMNS 1024
#define SIZES 4

static F(generator) generator;
static F(size) sizes[SIZES];
static int sized[SIZES], nsized;

static int fail(const char *what, const char *detail)
{
    fprintf(stderr, "replay: %s%s\n", what, detail);
    return 1;
}

/* Splits `line` at commas in place; returns how many cells. */
static int split(char *line, char **cells)
{
    int n = 0;
    char *p = line;
    line[strcspn(line, "\r\n")] = '\0';
    cells[n++] = p;
    while ((p = strchr(p, ',')) != NULL && n < COLUMNS) {
        *p++ = '\0';
        cells[n++] = p;
    }
    return n;
}

static void number(double x)
{
    if (x == x)
        printf(",%.17g", x);
    else
        printf(",");
}

/* Adds parameter k to those sized; 0 where it is already or there is no room. */
static int size(int k)
{
    int j;
    for (j = 0; j < nsized; j++)
        if (sized[j] == k)
            return 0;
    if (k < 0 || nsized == SIZES)
        return 0;
    sized[nsized++] = k;
    return 1;
}

/* Sets up the sizes over the generator as set up, at the noise levels `noise`. */
static int start_sizes(const char *noise, int memory, int window)
{
    double levels[M(RESIDUALS) > 0 ? M(RESIDUALS) : 1];
    const char *p = noise;
    int j, status;
    for (j = 0; j < M(RESIDUALS); j++) {
        levels[j] = p != NULL ? atof(p) : 1.0;
        p = p != NULL ? strchr(p, ',') : NULL;
        p = p != NULL ? p + 1 : NULL;
    }
    for (j = 0; j < nsized; j++) {
        status = F(size_init)(&sizes[j], &generator, sized[j], levels, memory);
        if (status != BGC_OK)
            return fail("size: ", F(status_text)(status));
        F(size_set_correlation)(&sizes[j], window);
    }
    return 0;
}

int main(int argc, char **argv)
{
    static char line[LINE];
    char *cells[COLUMNS];
    int column[M(RAW) > 0 ? M(RAW) : 1], time = -1, n, k, j, status, degree;
    double raw[M(RAW) > 0 ? M(RAW) : 1];
    F(output) out;
    FILE *record;
    const char *noise = NULL;
    int memory = 2000;
    if (argc < 4)
        return fail("usage: replay RECORD.csv STEP WINDOW [options]", "");
    degree = M(ORDER) > 3 ? M(ORDER) : 3;
    status = F(init)(&generator, &F(default_params), atof(argv[2]), atoi(argv[3]), degree);
    if (status != BGC_OK)
        return fail("init: ", F(status_text)(status));
    for (k = 4; k < argc; k++) {
        if (strcmp(argv[k], "--adaptive") == 0) {
            F(set_adaptive)(&generator, 1);
        } else if (strcmp(argv[k], "--debounce") == 0 && k + 1 < argc) {
            F(set_debounce)(&generator, (unsigned)atoi(argv[++k]));
        } else if (strcmp(argv[k], "--integration") == 0 && k + 1 < argc) {
            if (strcmp(argv[++k], "start") == 0)
                F(integrate_from_start)(&generator);
            else if (F(set_integration_window)(&generator, atoi(argv[k])) != BGC_OK)
                return fail("bad integration window ", argv[k]);
        } else if (strcmp(argv[k], "--noise") == 0 && k + 1 < argc) {
            noise = argv[++k];
        } else if (strcmp(argv[k], "--memory") == 0 && k + 1 < argc) {
            memory = atoi(argv[++k]);
        } else if (strcmp(argv[k], "--size") == 0 && k + 1 < argc) {
            k++;
            for (j = 0; j < M(PARAMETERS); j++)
                if (strcmp(F(parameter_names)[j], argv[k]) == 0)
                    break;
            if (j == M(PARAMETERS) || !size(j))
                return fail("cannot size ", argv[k]);
        } else if (strcmp(argv[k], "--sizes") == 0 && k + 1 < argc) {
            int wanted = atoi(argv[++k]);
            for (j = 0; j < M(PARAMETERS) && nsized < wanted; j++)
                if (F(sizable)[j])
                    size(j);
        } else if (strcmp(argv[k], "--threshold") == 0 && k + 1 < argc) {
            const char *arg = argv[++k], *eq = strchr(arg, '=');
            int found = 0;
            for (j = 0; eq != NULL && j < M(RESIDUALS); j++) {
                const char *name = F(residual_names)[j];
                if (strlen(name) == (size_t)(eq - arg) && strncmp(name, arg, (size_t)(eq - arg)) == 0) {
                    F(set_threshold)(&generator, j, atof(eq + 1));
                    found = 1;
                }
            }
            if (!found)
                return fail("no residual for ", arg);
        } else {
            return fail("unknown option ", argv[k]);
        }
    }
    if (start_sizes(noise, memory, atoi(argv[3])) != 0)
        return 1;
    record = fopen(argv[1], "r");
    if (record == NULL || fgets(line, LINE, record) == NULL)
        return fail("cannot read ", argv[1]);
    n = split(line, cells);
    for (j = 0; j < M(RAW); j++)
        column[j] = -1;
    for (k = 0; k < n; k++) {
        if (strcmp(cells[k], "t") == 0)
            time = k;
        for (j = 0; j < M(RAW); j++)
            if (strcmp(cells[k], F(raw_names)[j]) == 0)
                column[j] = k;
    }
    if (time < 0)
        return fail("no column t in ", argv[1]);
    for (j = 0; j < M(RAW); j++)
        if (column[j] < 0)
            return fail("no column for ", F(raw_names)[j]);
    printf("t");
    for (j = 0; j < M(RESIDUALS); j++)
        printf(",%s", F(residual_names)[j]);
    for (j = 0; j < M(RESIDUALS); j++)
        printf(",threshold_%s", F(residual_names)[j]);
    for (j = 0; j < M(RESIDUALS); j++)
        printf(",alarm_%s", F(residual_names)[j]);
    printf(",candidates");
    for (j = 0; j < nsized; j++) {
        const char *name = F(parameter_names)[sized[j]];
        printf(",size_%s,size_%s_half_width,size_%s_misfit", name, name, name);
    }
    printf("\n");
    while (fgets(line, LINE, record) != NULL) {
        int alarms[M(RESIDUALS) > 0 ? M(RESIDUALS) : 1], found[M(COMPONENTS) > 0 ? M(COMPONENTS) : 1], count;
        n = split(line, cells);
        for (j = 0; j < M(RAW); j++)
            raw[j] = column[j] < n ? atof(cells[column[j]]) : NAN;
        for (j = 0; j < nsized; j++)
            F(size_push)(&sizes[j], atof(cells[time]), raw);
        if (!F(push)(&generator, atof(cells[time]), raw, &out))
            continue;
        printf("%.17g", out.at);
        for (j = 0; j < M(RESIDUALS); j++)
            number(out.residuals[j]);
        for (j = 0; j < M(RESIDUALS); j++)
            number(out.thresholds[j]);
        for (j = 0; j < M(RESIDUALS); j++) {
            printf(",%d", out.alarms[j]);
            alarms[j] = out.alarms[j];
        }
        count = F(candidates)(alarms, found);
        printf(",");
        for (j = 0; j < count; j++)
            printf("%s%s", j > 0 ? " " : "", F(component_names)[found[j]]);
        for (j = 0; j < nsized; j++) {
            bgc_size e = F(size_estimate)(&sizes[j]);
            printf(",%.17g,%.17g,%.17g", e.value, e.half_width, e.misfit);
        }
        printf("\n");
    }
    fclose(record);
    return 0;
}
