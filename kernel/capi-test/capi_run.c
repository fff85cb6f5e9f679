/*
 * capi_run: drives the kernel through its C ABI (kernel/include/massid_kernel.h).
 *
 *   capi_run --selftest        layout and error-path checks; exit status 0 if all pass
 *   capi_run RECORDING.csv     runs the fixed and the f32 pipeline over a massid-recording/1
 *                              file and prints, at every solve and at the end, the estimates
 *                              (raw bits in hex) and the ON/OFF times of a set of mixer
 *                              commands with the mixer rebuilt from the current CoM estimate.
 *
 * tests/tests/capi.rs builds this with gcc against libmassid_kernel_capi.a and compares the
 * output with the same run made through the Rust API: it must be identical.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <stddef.h>

#include "massid_kernel.h"

/* Mixer commands, Q8.24 bits (force N, torque N m); the f32 runs use bits / 2^24 (exact). */
#define N_COMMANDS 4
static const int32_t COMMANDS[N_COMMANDS][6] = {
    {838861, 0, 0, 0, 0, 0},                    /* 0.05 N along x */
    {0, 0, 0, 0, 0, 83886},                     /* 0.005 N m about z */
    {335544, -503316, 167772, 33554, -16777, 50331}, /* mixed */
    {5033165, 5033165, 5033165, 0, 0, 0},       /* 0.3 N per axis: scaled down */
};
#define PERIOD_MS 200
#define MIN_PULSE_MS 10

static int failures = 0;

static void check(int ok, const char *what) {
    if (!ok) {
        fprintf(stderr, "selftest FAILED: %s\n", what);
        failures++;
    }
}

/* --options mode: the pipeline options C callers can choose, and gaps as one call each. */
static const massid_options *g_opts = NULL;
static int g_gaps_at_once = 0;
static const massid_options OPTIONS = {1, 1, {2077.0f, 2070.0f, 2058.0f}, 0.9999f};

static int selftest(void) {
    massid_satellite_params sp;
    static massid_pipeline p;
    static massid_mixer m;
    massid_tick_report r;
    massid_estimates_fixed ef;
    massid_firing f;
    const uint16_t g[3] = {2077, 2070, 2058};

    check(massid_type_size(0) == sizeof(massid_satellite_params), "sizeof(massid_satellite_params)");
    check(massid_type_size(1) == sizeof(massid_tick_report), "sizeof(massid_tick_report)");
    check(massid_type_size(2) == sizeof(massid_estimates_fixed), "sizeof(massid_estimates_fixed)");
    check(massid_type_size(3) == sizeof(massid_estimates_f32), "sizeof(massid_estimates_f32)");
    check(massid_type_size(4) == sizeof(massid_firing), "sizeof(massid_firing)");
    check(massid_type_size(5) == sizeof(massid_pipeline), "sizeof(massid_pipeline)");
    check(massid_type_size(6) == sizeof(massid_mixer), "sizeof(massid_mixer)");
    check(massid_type_size(7) == sizeof(massid_options), "sizeof(massid_options)");
    check(massid_pipeline_state_bytes(1) < sizeof(massid_pipeline), "fixed state fits the block");
    check(massid_pipeline_state_bytes(0) < sizeof(massid_pipeline), "f32 state fits the block");
    check(massid_mixer_state_bytes(1) < sizeof(massid_mixer), "fixed mixer fits the block");

    check(massid_params_sph2(NULL) == MASSID_NULL_POINTER, "params NULL");
    check(massid_params_sph2(&sp) == MASSID_OK, "params sph2");
    check(sp.thrust_n[0] > 0.10f && sp.thrust_n[0] < 0.11f, "sph2 thrust 1 is 0.1085 N");

    memset(&p, 0, sizeof p);
    check(massid_fixed_tick(&p, g, 0, &r) == MASSID_NOT_INITIALISED, "tick before init");
    check(massid_fixed_estimates(&p, &ef) == MASSID_NOT_INITIALISED, "estimates before init");
    check(massid_fixed_init(NULL, &sp, 1) == MASSID_NULL_POINTER, "init NULL block");
    check(massid_fixed_init(&p, NULL, 1) == MASSID_NULL_POINTER, "init NULL params");
    check(massid_fixed_init(&p, &sp, 0) == MASSID_BAD_PARAMETERS, "init zero period");
    {
        massid_options bad = OPTIONS;
        bad.forgetting = 2.0f;
        check(massid_fixed_init_with(&p, &sp, 1, &bad) == MASSID_BAD_PARAMETERS, "init_with forgetting > 1");
        bad = OPTIONS;
        bad.gyro_bias_counts[1] = 1e9f;
        check(massid_f32_init_with(&p, &sp, 1, &bad) == MASSID_BAD_PARAMETERS, "init_with bias off the ADC");
        check(massid_fixed_init_with(&p, &sp, 1, NULL) == MASSID_OK, "init_with NULL options");
        check(massid_fixed_tick_gaps(&p, 100000000000ULL, NULL) == MASSID_OK, "tick_gaps 1e11");
    }
    check(massid_fixed_init(&p, &sp, 1) == MASSID_OK, "init");
    check(massid_f32_tick(&p, g, 0, &r) == MASSID_NOT_INITIALISED, "f32 tick on a fixed block");
    check(massid_fixed_tick(&p, NULL, 0, &r) == MASSID_NULL_POINTER, "tick NULL gyro");
    check(massid_fixed_tick(&p, g, 0, NULL) == MASSID_OK, "tick with NULL report");
    check(massid_fixed_tick(&p, g, 0, &r) == MASSID_OK && r.event == MASSID_EVENT_COASTING, "coasting tick");
    check(massid_fixed_estimates(&p, NULL) == MASSID_NULL_POINTER, "estimates NULL out");
    check(massid_fixed_estimates(&p, &ef) == MASSID_OK && ef.status == MASSID_PIPELINE_IDLE, "idle estimates");

    {
        massid_satellite_params bad = sp;
        bad.thrust_n[3] = -1.0f;
        check(massid_fixed_mixer_init(&m, &bad, NULL, PERIOD_MS, MIN_PULSE_MS) == MASSID_BAD_PARAMETERS,
              "mixer with a negative thrust");
    }
    check(massid_fixed_mixer_init(&m, &sp, NULL, PERIOD_MS, 0) == MASSID_BAD_PARAMETERS, "mixer zero min pulse");
    check(massid_fixed_mixer_init(&m, &sp, NULL, PERIOD_MS, MIN_PULSE_MS) == MASSID_OK, "mixer init");
    check(massid_fixed_mix(&m, COMMANDS[0], COMMANDS[0] + 3, NULL) == MASSID_NULL_POINTER, "mix NULL out");
    check(massid_f32_mix(&m, (const float *)0, (const float *)0, &f) == MASSID_NULL_POINTER, "f32 mix NULL");
    check(massid_fixed_mix(&m, COMMANDS[0], COMMANDS[0] + 3, &f) == MASSID_OK, "mix");
    check(f.on_ms[0] < f.off_ms[0] || f.on_ms[6] < f.off_ms[6] || f.on_ms[1] < f.off_ms[1] || f.on_ms[7] < f.off_ms[7],
          "a +x force fires an x thruster");
    if (failures == 0) {
        printf("selftest: all checks passed\n");
    }
    return failures == 0 ? 0 : 1;
}

static void print_hex_i32(const int32_t *v, int n) {
    for (int i = 0; i < n; i++) printf(" %08x", (uint32_t)v[i]);
}

static void print_hex_f32(const float *v, int n) {
    for (int i = 0; i < n; i++) {
        uint32_t b;
        memcpy(&b, &v[i], sizeof b);
        printf(" %08x", b);
    }
}

static void print_flags(const uint8_t *v, int n) {
    for (int i = 0; i < n; i++) printf("%d", v[i] != 0);
}

static void print_firing(const char *name, long t, int k, massid_status s, const massid_firing *f) {
    printf("%s t=%ld mix%d status=%d on", name, t, k, (int)s);
    for (int i = 0; i < MASSID_N_THRUSTERS; i++) printf(" %u", s == MASSID_OK ? f->on_ms[i] : 0u);
    printf(" off");
    for (int i = 0; i < MASSID_N_THRUSTERS; i++) printf(" %u", s == MASSID_OK ? f->off_ms[i] : 0u);
    printf("\n");
}

/* One recording row. */
typedef struct {
    long time_ms;
    uint16_t gyro[3];
    uint16_t thrusters;
} row_t;

static row_t *read_recording(const char *path, size_t *n_out) {
    FILE *fp = fopen(path, "r");
    if (!fp) {
        fprintf(stderr, "%s: cannot open\n", path);
        return NULL;
    }
    size_t cap = 1 << 16, n = 0;
    row_t *rows = malloc(cap * sizeof *rows);
    char line[512];
    int header = 0;
    long line_no = 0;
    while (rows && fgets(line, sizeof line, fp)) {
        line_no++;
        if (line[0] == '#') continue;
        if (!header) {
            header = 1;
            continue;
        }
        long t, g0, g1, g2, a0, a1, a2, w;
        if (sscanf(line, "%ld,%ld,%ld,%ld,%ld,%ld,%ld,%ld", &t, &g0, &g1, &g2, &a0, &a1, &a2, &w) != 8 ||
            g0 < 0 || g0 > 4095 || g1 < 0 || g1 > 4095 || g2 < 0 || g2 > 4095 || w < 0 || w > 4095) {
            fprintf(stderr, "%s:%ld: not a valid recording row\n", path, line_no);
            free(rows);
            fclose(fp);
            return NULL;
        }
        if (n == cap) {
            cap *= 2;
            row_t *bigger = realloc(rows, cap * sizeof *rows);
            if (!bigger) {
                free(rows);
                rows = NULL;
                break;
            }
            rows = bigger;
        }
        rows[n].time_ms = t;
        rows[n].gyro[0] = (uint16_t)g0;
        rows[n].gyro[1] = (uint16_t)g1;
        rows[n].gyro[2] = (uint16_t)g2;
        rows[n].thrusters = (uint16_t)w;
        n++;
    }
    fclose(fp);
    *n_out = n;
    return rows;
}

#define RUN_FLAVOUR(NAME, CT, INIT, TICK, GAP, GAPS, FINISH, EST, EST_T, MFROM, MIX, PRINT, CMD)          \
    static int run_##NAME(const row_t *rows, size_t n, const massid_satellite_params *sp) {           \
        static massid_pipeline p;                                                                     \
        static massid_mixer m;                                                                        \
        massid_tick_report r;                                                                         \
        EST_T e;                                                                                      \
        massid_firing f;                                                                              \
        if (INIT(&p, sp, 1, g_opts) != MASSID_OK) {                                                   \
            printf(#NAME " init-error\n");                                                            \
            return 1;                                                                                 \
        }                                                                                             \
        long last = -1;                                                                               \
        for (size_t i = 0; i <= n; i++) {                                                             \
            int solved = 0;                                                                           \
            long t;                                                                                   \
            if (i < n) {                                                                              \
                t = rows[i].time_ms;                                                                  \
                if (last >= 0 && t <= last) continue; /* duplicate: the first row wins */             \
                if (g_gaps_at_once && last >= 0 && last + 1 < t) {                                    \
                    GAPS(&p, (uint64_t)(t - last - 1), &r);                                           \
                    last = t - 1;                                                                     \
                    if (r.event == MASSID_EVENT_SOLVED) solved = 1;                                   \
                }                                                                                     \
                while (last >= 0 && last + 1 < t) {                                                   \
                    GAP(&p, &r);                                                                      \
                    last++;                                                                           \
                    if (r.event == MASSID_EVENT_SOLVED) solved = 1;                                   \
                }                                                                                     \
                TICK(&p, rows[i].gyro, rows[i].thrusters, &r);                                        \
                last = t;                                                                             \
                if (r.event == MASSID_EVENT_SOLVED) solved = 1;                                       \
            } else {                                                                                  \
                uint8_t st;                                                                           \
                FINISH(&p, &st);                                                                      \
                t = last + 1;                                                                         \
                solved = 1;                                                                           \
            }                                                                                         \
            if (!solved) continue;                                                                    \
            EST(&p, &e);                                                                              \
            printf(#NAME " t=%ld estimates status=%d firings=%u updates=%u resets=%u com", t,          \
                   e.status, e.firings, e.updates, e.resets);                                         \
            PRINT(e.delta_com_m, 3);                                                                  \
            printf(" theta");                                                                         \
            PRINT(e.theta_inertia, 6);                                                                \
            printf(" unobs ");                                                                        \
            print_flags(e.unobservable_com, 3);                                                       \
            print_flags(e.unobservable_inertia, 6);                                                   \
            printf("\n");                                                                             \
            massid_status ms = MFROM(&m, sp, &p, PERIOD_MS, MIN_PULSE_MS);                            \
            for (int k = 0; k < N_COMMANDS; k++) {                                                    \
                CT cmd[6];                                                                            \
                for (int j = 0; j < 6; j++) cmd[j] = CMD(COMMANDS[k][j]);                             \
                massid_status s = ms == MASSID_OK ? MIX(&m, cmd, cmd + 3, &f) : ms;                   \
                print_firing(#NAME, t, k, s, &f);                                                     \
            }                                                                                         \
        }                                                                                             \
        return 0;                                                                                     \
    }

#define CMD_FIXED(bits) (bits)
#define CMD_F32(bits) ((float)(bits) / (float)MASSID_Q24_ONE)

RUN_FLAVOUR(fixed, int32_t, massid_fixed_init_with, massid_fixed_tick, massid_fixed_tick_gap, massid_fixed_tick_gaps,
            massid_fixed_finish,
            massid_fixed_estimates, massid_estimates_fixed, massid_fixed_mixer_from_pipeline, massid_fixed_mix,
            print_hex_i32, CMD_FIXED)
RUN_FLAVOUR(f32, float, massid_f32_init_with, massid_f32_tick, massid_f32_tick_gap, massid_f32_tick_gaps,
            massid_f32_finish,
            massid_f32_estimates, massid_estimates_f32, massid_f32_mixer_from_pipeline, massid_f32_mix,
            print_hex_f32, CMD_F32)

int main(int argc, char **argv) {
    if (argc == 2 && strcmp(argv[1], "--selftest") == 0) return selftest();
    if (argc == 3 && strcmp(argv[1], "--options") == 0) {
        g_opts = &OPTIONS;
        g_gaps_at_once = 1;
    } else if (argc != 2) {
        fprintf(stderr, "usage: capi_run --selftest | capi_run [--options] RECORDING.csv\n");
        return 2;
    }
    size_t n = 0;
    row_t *rows = read_recording(argv[argc - 1], &n);
    if (!rows) return 1;
    massid_satellite_params sp;
    massid_params_sph2(&sp);
    int rc = run_fixed(rows, n, &sp) | run_f32(rows, n, &sp);
    free(rows);
    return rc;
}
