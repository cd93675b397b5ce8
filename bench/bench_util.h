/* bench_util.h - shared helpers for ghostsim's benchmarks (header-only, C99
   and C++11, every function static).

   Each bench program includes it after defining nothing special (it asks for
   POSIX itself if the includer did not). What it gives:

     CLOCK      double bu_now(void);                 CLOCK_MONOTONIC, seconds
                double bu_cpu_now(void);             this thread's CPU seconds
                    (CLOCK_THREAD_CPUTIME_ID: time the thread was not
                    running does not count; a system call, ~0.1-0.3 us, so
                    for spans of a millisecond and more)
     TIMING     double bu_median(double *v, int n);  sorts v in place
                double bu_time_median(fn, user, repeats, inner);
                    seconds per call of fn(user): median over `repeats` runs,
                    each timing `inner` calls in a row
                double bu_cpu_time_median(fn, user, repeats, inner);
                    the same in thread CPU time (make each run >= ~1 ms)
     ARGS       bu_args a; bu_parse_args(argc, argv, "name", &a);
                    --quick, --out FILE (default bench/results/NAME.json)
     JSON       bu_json *j = bu_json_open(path)  ...  bu_json_close(j)
                bu_json_obj_begin / bu_json_obj_end / bu_json_arr_begin /
                bu_json_arr_end (key may be NULL inside an array)
                bu_json_num / bu_json_int / bu_json_str / bu_json_bool /
                bu_json_null, each (j, key or NULL, value)
                bu_json_num_array(j, key, values, n)
                Commas and indentation are handled for you. Non-finite
                numbers are written as null (JSON has no NaN).
     MACHINE    bu_json_machine(j): writes "machine": {...} (uname, the CPU
                model from /proc/cpuinfo, online cores)
     HEADER     bu_json_header(j, "name", quick): writes "bench", "quick" and
                "machine" in one go, right after bu_json_obj_begin(j, NULL)
     MISC       bu_sink(double): keeps a value alive against the optimizer
                bu_mkdir_for(path): creates the directory part of a path

   The JSON layout every bench writes is in bench/README.md. API is stable:
   add functions, do not change these. */
#ifndef BENCH_UTIL_H
#define BENCH_UTIL_H

#if !defined(_POSIX_C_SOURCE) && !defined(__cplusplus)
#define _POSIX_C_SOURCE 200809L
#endif

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/utsname.h>
#include <time.h>
#include <unistd.h>

#if defined(__GNUC__)
#define BU__UNUSED __attribute__((unused))
#else
#define BU__UNUSED
#endif

#define BU__MAX_DEPTH 32

/* ---- clock and timing ---------------------------------------------------- */

BU__UNUSED static double bu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

/* CPU seconds this thread has run: immune to the time a busy machine
   keeps it waiting. */
BU__UNUSED static double bu_cpu_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

BU__UNUSED static int bu__cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* Median of v[0..n-1]; sorts v in place. 0 for n <= 0. */
BU__UNUSED static double bu_median(double *v, int n)
{
    if (n <= 0) return 0.0;
    qsort(v, (size_t)n, sizeof *v, bu__cmp_double);
    return (n & 1) ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* Value at quantile q (0..1) of v[0..n-1], nearest rank; sorts v in place. */
BU__UNUSED static double bu_quantile(double *v, int n, double q)
{
    int i;
    if (n <= 0) return 0.0;
    qsort(v, (size_t)n, sizeof *v, bu__cmp_double);
    i = (int)ceil(q * n) - 1;
    if (i < 0) i = 0;
    if (i >= n) i = n - 1;
    return v[i];
}

typedef void (*bu_fn)(void *user);

/* Seconds per call of fn(user) on `clock`: the median over `repeats` runs
   (at most 1024), each of which times `inner` calls in a row. */
BU__UNUSED static double bu__time_median_on(double (*clock)(void), bu_fn fn, void *user, int repeats,
                                 int inner)
{
    double v[1024];
    int r, i;
    if (repeats < 1) repeats = 1;
    if (repeats > 1024) repeats = 1024;
    if (inner < 1) inner = 1;
    for (r = 0; r < repeats; ++r) {
        double t0 = clock();
        for (i = 0; i < inner; ++i) fn(user);
        v[r] = (clock() - t0) / inner;
    }
    return bu_median(v, repeats);
}

/* On the monotonic clock (bu_now). */
BU__UNUSED static double bu_time_median(bu_fn fn, void *user, int repeats, int inner)
{
    return bu__time_median_on(bu_now, fn, user, repeats, inner);
}

/* In this thread's CPU time (bu_cpu_now): for runs of a millisecond or
   more on a busy machine. */
BU__UNUSED static double bu_cpu_time_median(bu_fn fn, void *user, int repeats, int inner)
{
    return bu__time_median_on(bu_cpu_now, fn, user, repeats, inner);
}

/* Keeps a computed value alive so the optimizer cannot drop the work. */
BU__UNUSED static volatile double bu__sink_value;
BU__UNUSED static void bu_sink(double x) { bu__sink_value += x; }

/* ---- arguments ------------------------------------------------------------- */

typedef struct bu_args {
    int quick;            /* --quick given */
    char out[1024];       /* --out FILE, default bench/results/NAME.json */
} bu_args;

/* Parses --quick, --out FILE and --help. Returns 0 to go on, 1 when the
   program should exit with status 0 (help), -1 on a bad argument (a message
   went to stderr). */
BU__UNUSED static int bu_parse_args(int argc, char **argv, const char *name, bu_args *a)
{
    int i;
    memset(a, 0, sizeof *a);
    snprintf(a->out, sizeof a->out, "bench/results/%s.json", name);
    for (i = 1; i < argc; ++i) {
        if (strcmp(argv[i], "--quick") == 0) {
            a->quick = 1;
        } else if (strcmp(argv[i], "--out") == 0 && i + 1 < argc) {
            snprintf(a->out, sizeof a->out, "%s", argv[++i]);
        } else if (strcmp(argv[i], "--help") == 0 || strcmp(argv[i], "-h") == 0) {
            fprintf(stderr, "usage: %s [--quick] [--out FILE.json]\n", argv[0]);
            return 1;
        } else {
            fprintf(stderr, "%s: unknown argument '%s'\nusage: %s [--quick] [--out FILE.json]\n",
                    name, argv[i], argv[0]);
            return -1;
        }
    }
    return 0;
}

/* Creates every directory on the way to the file `path` (like mkdir -p on
   its dirname). Returns 0 on success. */
BU__UNUSED static int bu_mkdir_for(const char *path)
{
    char buf[1024];
    size_t i, n = strlen(path);
    if (n >= sizeof buf) return -1;
    memcpy(buf, path, n + 1);
    for (i = 1; i < n; ++i) {
        if (buf[i] != '/') continue;
        buf[i] = 0;
        if (mkdir(buf, 0777) != 0 && errno != EEXIST) return -1;
        buf[i] = '/';
    }
    return 0;
}

/* ---- JSON writer ----------------------------------------------------------- */

typedef struct bu_json {
    FILE *f;
    int depth;
    int count[BU__MAX_DEPTH];   /* items written at each depth */
    int failed;
} bu_json;

/* Opens `path` for writing (creating its directory). NULL on failure. */
BU__UNUSED static bu_json *bu_json_open(const char *path)
{
    bu_json *j;
    FILE *f;
    bu_mkdir_for(path);
    f = fopen(path, "w");
    if (!f) {
        fprintf(stderr, "bench: cannot write %s: %s\n", path, strerror(errno));
        return NULL;
    }
    j = (bu_json *)calloc(1, sizeof *j);
    if (!j) { fclose(f); return NULL; }
    j->f = f;
    return j;
}

/* Closes the file. Returns 0 when everything was written and every object
   and array was closed. */
BU__UNUSED static int bu_json_close(bu_json *j)
{
    int bad;
    if (!j) return -1;
    fputc('\n', j->f);
    bad = j->failed || j->depth != 0 || ferror(j->f);
    if (fclose(j->f) != 0) bad = 1;
    free(j);
    return bad ? -1 : 0;
}

BU__UNUSED static void bu__json_str_raw(FILE *f, const char *s)
{
    fputc('"', f);
    for (; s && *s; ++s) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\') { fputc('\\', f); fputc(c, f); }
        else if (c == '\n') fputs("\\n", f);
        else if (c == '\t') fputs("\\t", f);
        else if (c == '\r') fputs("\\r", f);
        else if (c < 0x20) fprintf(f, "\\u%04x", c);
        else fputc(c, f);
    }
    fputc('"', f);
}

/* Writes the separator, the indentation and the key (if any). */
BU__UNUSED static void bu__json_item(bu_json *j, const char *key)
{
    int i;
    if (j->depth > 0) {
        if (j->count[j->depth - 1]++ > 0) fputc(',', j->f);
        fputc('\n', j->f);
        for (i = 0; i < j->depth; ++i) fputs("  ", j->f);
    }
    if (key) {
        bu__json_str_raw(j->f, key);
        fputs(": ", j->f);
    }
}

BU__UNUSED static void bu__json_open_container(bu_json *j, const char *key, char c)
{
    bu__json_item(j, key);
    fputc(c, j->f);
    if (j->depth >= BU__MAX_DEPTH) { j->failed = 1; return; }
    j->count[j->depth++] = 0;
}

BU__UNUSED static void bu__json_close_container(bu_json *j, char c)
{
    int i, had;
    if (j->depth <= 0) { j->failed = 1; return; }
    had = j->count[--j->depth];
    if (had) {
        fputc('\n', j->f);
        for (i = 0; i < j->depth; ++i) fputs("  ", j->f);
    }
    fputc(c, j->f);
}

BU__UNUSED static void bu_json_obj_begin(bu_json *j, const char *key) { bu__json_open_container(j, key, '{'); }
BU__UNUSED static void bu_json_obj_end(bu_json *j)                    { bu__json_close_container(j, '}'); }
BU__UNUSED static void bu_json_arr_begin(bu_json *j, const char *key) { bu__json_open_container(j, key, '['); }
BU__UNUSED static void bu_json_arr_end(bu_json *j)                    { bu__json_close_container(j, ']'); }

BU__UNUSED static void bu_json_num(bu_json *j, const char *key, double v)
{
    bu__json_item(j, key);
    if (isfinite(v)) fprintf(j->f, "%.17g", v);
    else fputs("null", j->f);
}

BU__UNUSED static void bu_json_int(bu_json *j, const char *key, long long v)
{
    bu__json_item(j, key);
    fprintf(j->f, "%lld", v);
}

BU__UNUSED static void bu_json_str(bu_json *j, const char *key, const char *s)
{
    bu__json_item(j, key);
    if (s) bu__json_str_raw(j->f, s);
    else fputs("null", j->f);
}

BU__UNUSED static void bu_json_bool(bu_json *j, const char *key, int b)
{
    bu__json_item(j, key);
    fputs(b ? "true" : "false", j->f);
}

BU__UNUSED static void bu_json_null(bu_json *j, const char *key)
{
    bu__json_item(j, key);
    fputs("null", j->f);
}

/* An array of numbers on one line. */
BU__UNUSED static void bu_json_num_array(bu_json *j, const char *key, const double *v, int n)
{
    int i;
    bu__json_item(j, key);
    fputc('[', j->f);
    for (i = 0; i < n; ++i) {
        if (i) fputs(", ", j->f);
        if (isfinite(v[i])) fprintf(j->f, "%.17g", v[i]);
        else fputs("null", j->f);
    }
    fputc(']', j->f);
}

/* ---- machine --------------------------------------------------------------- */

/* The CPU model from /proc/cpuinfo ("unknown" if absent) into buf. */
BU__UNUSED static void bu_cpu_model(char *buf, size_t size)
{
    char line[512];
    FILE *f = fopen("/proc/cpuinfo", "r");
    snprintf(buf, size, "unknown");
    if (!f) return;
    while (fgets(line, sizeof line, f)) {
        if (strncmp(line, "model name", 10) == 0) {
            char *p = strchr(line, ':');
            size_t n;
            if (!p) break;
            p++;
            while (*p == ' ' || *p == '\t') p++;
            n = strlen(p);
            while (n > 0 && (p[n - 1] == '\n' || p[n - 1] == ' ')) p[--n] = 0;
            snprintf(buf, size, "%s", p);
            break;
        }
    }
    fclose(f);
}

BU__UNUSED static int bu_cores(void)
{
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n > 0 ? (int)n : 1;
}

/* Writes "machine": {"sysname", "release", "machine", "nodename", "cpu",
   "cores"}. */
BU__UNUSED static void bu_json_machine(bu_json *j)
{
    struct utsname u;
    char cpu[256];
    bu_cpu_model(cpu, sizeof cpu);
    bu_json_obj_begin(j, "machine");
    if (uname(&u) == 0) {
        bu_json_str(j, "sysname", u.sysname);
        bu_json_str(j, "release", u.release);
        bu_json_str(j, "arch", u.machine);
        bu_json_str(j, "nodename", u.nodename);
    }
    bu_json_str(j, "cpu", cpu);
    bu_json_int(j, "cores", bu_cores());
    bu_json_obj_end(j);
}

/* "bench", "quick", "machine": the first three keys of every result file.
   Call right after bu_json_obj_begin(j, NULL). */
BU__UNUSED static void bu_json_header(bu_json *j, const char *name, int quick)
{
    bu_json_str(j, "bench", name);
    bu_json_bool(j, "quick", quick);
    bu_json_machine(j);
}

/* Writes one plot: {"title", "xlabel", "ylabel", "log", "series": [...]}
   with nseries series of n points each (x[s], y[s], names[s]). Call inside
   the "plots" array. For series of different lengths, write the object by
   hand with the functions above. */
BU__UNUSED static void bu_json_plot(bu_json *j, const char *title, const char *xlabel,
                                    const char *ylabel, int log_scale, int nseries,
                                    const char *const *names, const double *const *x,
                                    const double *const *y, const int *n)
{
    int s;
    bu_json_obj_begin(j, NULL);
    bu_json_str(j, "title", title);
    bu_json_str(j, "xlabel", xlabel);
    bu_json_str(j, "ylabel", ylabel);
    bu_json_bool(j, "log", log_scale);
    bu_json_arr_begin(j, "series");
    for (s = 0; s < nseries; ++s) {
        bu_json_obj_begin(j, NULL);
        bu_json_str(j, "name", names[s]);
        bu_json_num_array(j, "x", x[s], n[s]);
        bu_json_num_array(j, "y", y[s], n[s]);
        bu_json_obj_end(j);
    }
    bu_json_arr_end(j);
    bu_json_obj_end(j);
}

#endif /* BENCH_UTIL_H */
