/* What every bgc generator is built of, shared by the headers of several models. */
#ifndef BGC_RUNTIME_TYPES
#define BGC_RUNTIME_TYPES

/* The longest estimator window (samples) a generator takes: its storage is fixed, so that a
   firmware knows it at link time. Define before including to change it. */
#ifndef BGC_MAX_WINDOW
#define BGC_MAX_WINDOW 1001
#endif

/* The highest degree of a Savitzky-Golay fit a generator takes. */
#ifndef BGC_MAX_DEGREE
#define BGC_MAX_DEGREE 8
#endif

/* The longest integration window (samples) of a residual realised by integration. */
#ifndef BGC_MAX_REFERENCE
#define BGC_MAX_REFERENCE 2500
#endif

/* What an initialisation or a setting says. */
typedef enum {
    BGC_OK = 0,
    /* The step is not a positive finite number of seconds. */
    BGC_BAD_STEP,
    /* The degree is below the highest derivative read, or above BGC_MAX_DEGREE. */
    BGC_BAD_DEGREE,
    /* The window is even, not longer than the degree, or longer than BGC_MAX_WINDOW. */
    BGC_BAD_WINDOW,
    /* The fit's normal equations are singular. */
    BGC_SINGULAR_FIT,
    /* The integration window is negative or longer than BGC_MAX_REFERENCE. */
    BGC_BAD_INTEGRATION_WINDOW,
    /* A residual's index is out of range. */
    BGC_BAD_INDEX,
    /* No parameter has that index. */
    BGC_BAD_PARAMETER,
    /* A residual's noise level is not a positive finite number. */
    BGC_BAD_NOISE,
    /* A size estimate's memory is shorter than two samples. */
    BGC_BAD_MEMORY
} bgc_status;

/* A running trapezoidal integral from the first sample. */
typedef struct {
    double t, x, sum;
    int started;
} bgc_trapezoid;

/* The change of a running value over the last `samples` steps (0: since the first). */
typedef struct {
    int samples, next;
    long seen;
    double first;
    double buffer[BGC_MAX_REFERENCE + 1];
} bgc_reference;

/* A root found again at each sample, from the last one. */
typedef struct {
    double last;
    int found;
    unsigned long failures;
} bgc_root_finder;

/* A threshold on |residual| with a debounce. */
typedef struct {
    unsigned count;
    int alarm;
} bgc_threshold;

/* A parameter's estimate: its value, the half-width of its 95 % interval (HUGE_VAL until the
   residuals have told it) and what a change of it alone leaves of the residuals, in units of
   their noise (about 1 where it explains them all; HUGE_VAL until told). */
typedef struct {
    double value, half_width, misfit;
} bgc_size;

/* Recursive least squares for one parameter's change, with forgetting by information (the
   runtime's ChangeEstimator; the weights are its owner's). */
typedef struct {
    double forgetting, correlation, ss, sr, rr, count, information, seen;
} bgc_change;

#endif
