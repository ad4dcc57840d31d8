/* Whether the row `marks` (its `count` residuals, ascending) holds every alarm; with
   `exactly`, and no other residual. No alarm, no match. */
static int bgc_row_matches(const int *marks, int count, const int *alarms, int residuals,
                           int exactly)
{
    int k, held = 0, raised = 0, i = 0;
    for (k = 0; k < residuals; k++) {
        if (!alarms[k])
            continue;
        raised++;
        while (i < count && marks[i] < k)
            i++;
        if (i < count && marks[i] == k)
            held++;
    }
    return raised > 0 && held == raised && (!exactly || count == raised);
}

/* The components (indices into the FSM's rows, `start`/`marks` sparse) whose fault explains
   `alarms`: those whose signature equals them, or else those whose signature holds every
   alarm (`exactly` 0: the latter only). Written into `out`; returns how many. */
static int bgc_fsm_match(const int *start, const int *marks, int components, const int *alarms,
                         int residuals, int exactly, int *out)
{
    int c, found = 0;
    if (exactly) {
        for (c = 0; c < components; c++)
            if (bgc_row_matches(marks + start[c], start[c + 1] - start[c], alarms, residuals, 1))
                out[found++] = c;
        if (found > 0)
            return found;
    }
    for (c = 0; c < components; c++)
        if (bgc_row_matches(marks + start[c], start[c + 1] - start[c], alarms, residuals, 0))
            out[found++] = c;
    return found;
}
