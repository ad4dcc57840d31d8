/* The rates dx of the copy of the model at time t, state x and inputs u. */
typedef void (*bgc_rates)(const void *params, double t, const double *x, const double *u,
                          double *dx);

/* One classic Runge-Kutta step of length h from t0 of the n states x, the m inputs going
   from u0 to u1 linearly; `mid` holds m values, `k` 5 n. */
static void bgc_rk4(bgc_rates rates, const void *params, double t0, double h, const double *u0,
                    const double *u1, int m, double *mid, double *x, int n, double *k)
{
    double *k1 = k, *k2 = k + n, *k3 = k + 2 * n, *k4 = k + 3 * n, *y = k + 4 * n;
    int i;
    for (i = 0; i < m; i++)
        mid[i] = 0.5 * (u0[i] + u1[i]);
    rates(params, t0, x, u0, k1);
    for (i = 0; i < n; i++)
        y[i] = x[i] + 0.5 * h * k1[i];
    rates(params, t0 + 0.5 * h, y, mid, k2);
    for (i = 0; i < n; i++)
        y[i] = x[i] + 0.5 * h * k2[i];
    rates(params, t0 + 0.5 * h, y, mid, k3);
    for (i = 0; i < n; i++)
        y[i] = x[i] + h * k3[i];
    rates(params, t0 + h, y, u1, k4);
    for (i = 0; i < n; i++)
        x[i] += h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
}

/* The copy's state at `at`, linear between the kept samples (times `ht`, states `hx`, n per
   sample, a ring of `capacity` from `*head`, `*len` of them), into out: 1, or 0 when `at`
   is outside them. States before `at` are forgotten. */
static int bgc_replay_at(const double *ht, const double *hx, int n, int capacity, int *head,
                         int *len, double at, double *out)
{
    int i, first, second;
    double w;
    while (*len >= 2 && ht[(*head + 1) % capacity] <= at) {
        *head = (*head + 1) % capacity;
        (*len)--;
    }
    if (*len == 0)
        return 0;
    first = *head;
    if (at < ht[first])
        return 0;
    if (*len < 2) {
        if (at != ht[first])
            return 0;
        for (i = 0; i < n; i++)
            out[i] = hx[first * n + i];
        return 1;
    }
    second = (first + 1) % capacity;
    w = (at - ht[first]) / (ht[second] - ht[first]);
    for (i = 0; i < n; i++)
        out[i] = hx[first * n + i] + w * (hx[second * n + i] - hx[first * n + i]);
    return 1;
}
