/* The change of the running value `g` over the reference's window: zero until it fills. */
static double bgc_reference_push(bgc_reference *r, double g)
{
    int len = r->samples + 1;
    if (r->samples == 0) {
        if (!r->seen) {
            r->first = g;
            r->seen = 1;
        }
        return g - r->first;
    }
    r->buffer[r->next] = g;
    r->next = r->next + 1 == len ? 0 : r->next + 1;
    if (r->seen < len)
        r->seen++;
    if (r->seen < len)
        return 0.0;
    return g - r->buffer[r->next];
}
