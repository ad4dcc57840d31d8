/* x^n by repeated squaring, as Rust's powi computes it (so that both give the same bits). */
static double bgc_powi(double x, int n)
{
    unsigned k = n < 0 ? 0u - (unsigned)n : (unsigned)n;
    double r = 1.0;
    for (;;) {
        if (k & 1u)
            r *= x;
        k >>= 1;
        if (k == 0u)
            break;
        x *= x;
    }
    return n < 0 ? 1.0 / r : r;
}

/* The weights of the derivatives 0..order at sample `at` of a least-squares polynomial of
   `degree` over `window` samples `step` seconds apart: rows of (V'V)^-1 V', scaled to
   seconds, in w[k][j]. Positions are scaled to about +-1 so that the normal equations stay
   well conditioned. 0 where they are singular. */
static int bgc_fit_weights(int order, int degree, int window, int at, double step,
                           double w[BGC_MAX_DEGREE + 1][BGC_MAX_WINDOW])
{
    double a[BGC_MAX_DEGREE + 1][BGC_MAX_DEGREE + 1];
    int n = degree + 1, r, c, j, col, k;
    double scale = (window - 1) / 2.0 > 1.0 ? (window - 1) / 2.0 : 1.0;
    double factorial = 1.0;
    for (r = 0; r < n; r++) {
        for (c = 0; c < n; c++) {
            double sum = 0.0;
            for (j = 0; j < window; j++)
                sum += bgc_powi(((double)j - (double)at) / scale, r + c);
            a[r][c] = sum;
        }
        for (j = 0; j < window; j++)
            w[r][j] = bgc_powi(((double)j - (double)at) / scale, r);
    }
    for (col = 0; col < n; col++) {
        int pivot = col;
        for (r = col + 1; r < n; r++)
            if (fabs(a[r][col]) >= fabs(a[pivot][col]))
                pivot = r;
        if (fabs(a[pivot][col]) < 1e-300)
            return 0;
        for (c = 0; c < n; c++) {
            double swap = a[col][c];
            a[col][c] = a[pivot][c];
            a[pivot][c] = swap;
        }
        for (j = 0; j < window; j++) {
            double swap = w[col][j];
            w[col][j] = w[pivot][j];
            w[pivot][j] = swap;
        }
        for (r = 0; r < n; r++) {
            double f;
            if (r == col)
                continue;
            f = a[r][col] / a[col][col];
            if (f == 0.0)
                continue;
            for (c = 0; c < n; c++)
                a[r][c] -= f * a[col][c];
            for (j = 0; j < window; j++)
                w[r][j] -= f * w[col][j];
        }
    }
    for (k = 0; k <= order; k++) {
        double factor;
        if (k > 0)
            factorial *= k;
        /* d^k/dt^k of sum c_i tau^i at tau = 0 is k! c_k, and tau is t / (scale step). */
        factor = factorial / bgc_powi(scale * step, k) / a[k][k];
        for (j = 0; j < window; j++)
            w[k][j] *= factor;
    }
    return 1;
}

/* Whether the alarm is on after `residual` against `level`: it changes after `debounce`
   consecutive samples on the other side. A residual that is not a number counts as above. */
static int bgc_threshold_update(bgc_threshold *th, double residual, double level,
                                unsigned debounce)
{
    int above = residual != residual || fabs(residual) > level;
    if (above != th->alarm) {
        th->count++;
        if (th->count >= (debounce < 1u ? 1u : debounce)) {
            th->alarm = above;
            th->count = 0;
        }
    } else {
        th->count = 0;
    }
    return th->alarm;
}
