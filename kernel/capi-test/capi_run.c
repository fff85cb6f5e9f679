/*
 * capi_run: drives the kernel through its C ABI (kernel/include/massid_kernel.h).
 *
 *   capi_run --selftest        layout and error-path checks; exit status 0 if all pass
 *   capi_run --craft FILE      a craft's table and commands (format at run_craft_file): the
 *                              craft mixer's ON/OFF times, fixed and f32, per command
 *   capi_run --flight-id FILE  a craft, its nominal mass properties and a flight's samples:
 *                              the f32 identification's result (raw bits in hex)
 *   capi_run --fixed-flight-id FILE  the same through the integer-float identification
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
#include <math.h>

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

static void craft_selftest(const massid_satellite_params *sp);

static int selftest(void) {
    massid_satellite_params sp;
    static massid_pipeline p;
    static massid_mixer m;
    massid_tick_report r;
    massid_estimates_fixed ef;
    massid_firing f;
    const uint16_t g[3] = {2077, 2070, 2058};

    check(massid_abi_version() == MASSID_ABI_VERSION, "massid_abi_version() == MASSID_ABI_VERSION");
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
    craft_selftest(&sp);
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

#define CMD_F32(bits) ((float)(bits) / (float)MASSID_Q24_ONE)

/* ---- any craft (massid_craft, massid_craft_mixer, massid_flight_id) ---- */

static void craft_selftest(const massid_satellite_params *sp) {
    static massid_craft_mixer cm;
    static massid_flight_id id;
    static massid_fixed_flight_id fid;
    massid_craft c, one;
    massid_craft_firing cf;
    massid_flight_id_settings st;
    massid_flight_id_result res;
    uint8_t pairs = 9;
    const float zero3[3] = {0.0f, 0.0f, 0.0f};
    const float rate[3] = {0.0f, 0.0f, 0.01f};
    const float inertia[6] = {0.02f, 0.02f, 0.02f, 0.0f, 0.0f, 0.0f};
    const float fx_minus[3] = {-0.05f, 0.0f, 0.0f};
    const float fx_plus[3] = {0.05f, 0.0f, 0.0f};

    check(massid_craft_type_size(0) == sizeof(massid_craft), "sizeof(massid_craft)");
    check(massid_craft_type_size(1) == sizeof(massid_craft_firing), "sizeof(massid_craft_firing)");
    check(massid_craft_type_size(2) == sizeof(massid_craft_mixer), "sizeof(massid_craft_mixer)");
    check(massid_craft_type_size(3) == sizeof(massid_flight_id), "sizeof(massid_flight_id)");
    check(massid_craft_type_size(4) == sizeof(massid_flight_id_settings), "sizeof(massid_flight_id_settings)");
    check(massid_craft_type_size(5) == sizeof(massid_flight_id_result), "sizeof(massid_flight_id_result)");
    check(massid_craft_type_size(6) == sizeof(massid_fixed_flight_id), "sizeof(massid_fixed_flight_id)");
    check(massid_craft_type_size(7) == 0, "craft type size of an unknown code");
    check(offsetof(massid_craft, pressure_drop_n_per_extra) == 8 + 7 * 4 * MASSID_MAX_THRUSTERS,
          "massid_craft field offsets");
    check(offsetof(massid_flight_id_result, has_symmetry_statistic) ==
              offsetof(massid_flight_id_result, has_timing_statistic) + 1 &&
              offsetof(massid_flight_id_result, symmetry_statistic) ==
              offsetof(massid_flight_id_result, timing_statistic) + 4,
          "massid_flight_id_result field offsets");
    {
        /* The status rule: a statistic counts only where it is set, each against its level. */
        massid_flight_id_result r;
        memset(&r, 0, sizeof r);
        check(massid_flight_id_inconsistent(NULL) == 1, "inconsistent NULL");
        check(massid_flight_id_inconsistent(&r) == 0, "no statistic: consistent");
        r.timing_statistic = 1e6f;
        r.symmetry_statistic[1] = 1e6f;
        check(massid_flight_id_inconsistent(&r) == 0, "statistics not set: consistent");
        r.has_timing_statistic = 1;
        r.timing_statistic = 10.5f;
        check(massid_flight_id_inconsistent(&r) == 0, "timing 10.5: consistent");
        r.timing_statistic = 11.0f;
        check(massid_flight_id_inconsistent(&r) == 1, "timing 11: inconsistent");
        r.timing_statistic = 0.0f;
        r.has_symmetry_statistic[1] = 1;
        r.symmetry_statistic[1] = 12.5f;
        check(massid_flight_id_inconsistent(&r) == 0, "symmetry 12.5: consistent (a third of the level)");
        r.symmetry_statistic[1] = 13.0f;
        check(massid_flight_id_inconsistent(&r) == 1, "symmetry 13: inconsistent");
    }
    check(massid_craft_state_bytes(1) < sizeof(massid_craft_mixer), "fixed craft mixer fits the block");
    check(massid_craft_state_bytes(0) < sizeof(massid_craft_mixer), "f32 craft mixer fits the block");
    check(massid_craft_state_bytes(2) < sizeof(massid_flight_id), "identification fits the block");
    check(massid_craft_state_bytes(3) < sizeof(massid_fixed_flight_id), "integer-float identification fits its block");

    check(massid_craft_from_params(NULL, &c) == MASSID_NULL_POINTER, "craft_from_params NULL");
    check(massid_craft_from_params(sp, &c) == MASSID_OK && c.count == 12 && c.planar == 0, "craft of SPH2");
    memset(&cm, 0, sizeof cm);
    check(massid_f32_craft_mix(&cm, zero3, zero3, &cf) == MASSID_NOT_INITIALISED, "craft mix before init");
    check(massid_f32_craft_mixer_init(NULL, &c, NULL, PERIOD_MS, MIN_PULSE_MS) == MASSID_NULL_POINTER,
          "craft mixer NULL block");
    check(massid_f32_craft_mixer_init(&cm, NULL, NULL, PERIOD_MS, MIN_PULSE_MS) == MASSID_NULL_POINTER,
          "craft mixer NULL craft");
    {
        massid_craft bad = c;
        bad.count = 0;
        check(massid_f32_craft_mixer_init(&cm, &bad, NULL, PERIOD_MS, MIN_PULSE_MS) == MASSID_BAD_PARAMETERS,
              "craft of 0 thrusters");
        bad.count = 17;
        check(massid_fixed_craft_mixer_init(&cm, &bad, NULL, PERIOD_MS, MIN_PULSE_MS) == MASSID_BAD_PARAMETERS,
              "craft of 17 thrusters");
        bad = c;
        bad.thrust_n[11] = 0.0f;
        check(massid_f32_craft_mixer_init(&cm, &bad, NULL, PERIOD_MS, MIN_PULSE_MS) == MASSID_BAD_PARAMETERS,
              "craft with a zero thrust");
        bad = c;
        bad.pressure_drop_n_per_extra = -1.0f;
        check(massid_f32_craft_mixer_init(&cm, &bad, NULL, PERIOD_MS, MIN_PULSE_MS) == MASSID_BAD_PARAMETERS,
              "craft with a negative pressure drop");
    }
    check(massid_f32_craft_mixer_init(&cm, &c, NULL, PERIOD_MS, 0) == MASSID_BAD_PARAMETERS,
          "craft mixer zero min pulse");
    check(massid_f32_craft_mixer_init(&cm, &c, NULL, PERIOD_MS, MIN_PULSE_MS) == MASSID_OK, "SPH2 craft mixer");
    check(massid_f32_craft_mixer_rule(&cm, &pairs) == MASSID_OK && pairs == 1, "SPH2 gets the pair rules");
    check(massid_fixed_craft_mix(&cm, (const int32_t *)0, (const int32_t *)0, &cf) == MASSID_NULL_POINTER,
          "craft mix NULL");
    check(massid_fixed_craft_mix(&cm, COMMANDS[0], COMMANDS[0] + 3, &cf) == MASSID_NOT_INITIALISED,
          "fixed craft mix on an f32 block");
    check(massid_f32_craft_mix(&cm, fx_plus, zero3, NULL) == MASSID_NULL_POINTER, "craft mix NULL out");
    check(massid_f32_craft_mix(&cm, fx_plus, zero3, &cf) == MASSID_OK && cf.off_ms[12] == 0 && cf.on_ms[15] == 0,
          "SPH2 craft mix leaves slots 13-16 off");

    /* One thruster pushing +x through the centre: -x is out of reach. */
    memset(&one, 0, sizeof one);
    one.count = 1;
    one.thrust_dir[0][0] = 1.0f;
    one.thrust_n[0] = 0.1f;
    check(massid_f32_craft_mixer_init(&cm, &one, NULL, PERIOD_MS, MIN_PULSE_MS) == MASSID_OK, "1-thruster craft");
    check(massid_f32_craft_mixer_rule(&cm, &pairs) == MASSID_OK && pairs == 0, "1 thruster: allocation");
    check(massid_f32_craft_mix(&cm, fx_minus, zero3, &cf) == MASSID_OUT_OF_REACH, "1 thruster: -x out of reach");
    check(massid_f32_craft_mix(&cm, fx_plus, zero3, &cf) == MASSID_OK && cf.on_ms[0] < cf.off_ms[0],
          "1 thruster: +x fires it");

    /* Identification: settings, NULLs, uninitialised block, no data. */
    memset(&id, 0, sizeof id);
    check(massid_f32_flight_id_finish(&id) == MASSID_NOT_INITIALISED, "flight_id before init");
    check(massid_flight_id_settings_default(&c, inertia, zero3, 0.0f, &st) == MASSID_BAD_PARAMETERS,
          "settings with a zero period");
    check(massid_flight_id_settings_default(&c, NULL, zero3, 0.001f, &st) == MASSID_NULL_POINTER,
          "settings NULL inertia");
    check(massid_flight_id_settings_default(&c, inertia, zero3, 0.001f, &st) == MASSID_OK && st.gyroscopic == 1 &&
              st.max_window == 60000 && st.free[0] == 1,
          "settings of a 3-D craft");
    check(massid_f32_flight_id_init(&id, &c, NULL) == MASSID_NULL_POINTER, "flight_id NULL settings");
    {
        massid_flight_id_settings bad = st;
        bad.inertia_kgm2[0] = 0.0f;
        bad.inertia_kgm2[1] = 0.0f;
        bad.inertia_kgm2[2] = 0.0f;
        check(massid_f32_flight_id_init(&id, &c, &bad) == MASSID_BAD_PARAMETERS, "flight_id singular inertia");
        bad = st;
        bad.sensor = 3;
        check(massid_f32_flight_id_init(&id, &c, &bad) == MASSID_BAD_PARAMETERS, "flight_id bad sensor");
        /* A zeroed, negative or NaN turn weight would fly without a turn limit: refused. */
        bad = st;
        bad.turn_weight[1] = 0.0f;
        check(massid_f32_flight_id_init(&id, &c, &bad) == MASSID_BAD_PARAMETERS, "flight_id zero turn weight");
        bad.turn_weight[1] = -1.0f;
        check(massid_f32_flight_id_init(&id, &c, &bad) == MASSID_BAD_PARAMETERS, "flight_id negative turn weight");
        bad.turn_weight[1] = NAN;
        check(massid_f32_flight_id_init(&id, &c, &bad) == MASSID_BAD_PARAMETERS, "flight_id NaN turn weight");
        check(st.turn_weight[0] == 1.0f && st.turn_weight[1] == 1.0f && st.turn_weight[2] == 1.0f,
              "SPHERES-like default turn weights");
    }
    check(massid_f32_flight_id_init(&id, &c, &st) == MASSID_OK, "flight_id init");
    check(massid_f32_flight_id_push(&id, 0.001f, NULL, 1, 0) == MASSID_NULL_POINTER, "push NULL rate");
    check(massid_f32_flight_id_push(&id, 0.0f, rate, 1, 0) == MASSID_OK, "push");
    check(massid_f32_flight_id_solve(&id, NULL) == MASSID_NULL_POINTER, "solve NULL out");
    check(massid_f32_flight_id_solve(&id, &res) == MASSID_NO_DATA, "solve without data");

    /* The integer-float identification: its own block type, the same rules. */
    memset(&fid, 0, sizeof fid);
    check(massid_fixed_flight_id_finish(&fid) == MASSID_NOT_INITIALISED, "fixed flight_id before init");
    check(massid_fixed_flight_id_init(NULL, &c, &st) == MASSID_NULL_POINTER, "fixed flight_id NULL block");
    {
        massid_flight_id_settings bad = st;
        bad.inertia_kgm2[0] = 0.0f;
        bad.inertia_kgm2[1] = 0.0f;
        bad.inertia_kgm2[2] = 0.0f;
        check(massid_fixed_flight_id_init(&fid, &c, &bad) == MASSID_BAD_PARAMETERS,
              "fixed flight_id singular inertia");
    }
    check(massid_fixed_flight_id_init(&fid, &c, &st) == MASSID_OK, "fixed flight_id init");
    check(massid_fixed_flight_id_push(&fid, 0.001f, NULL, 1, 0) == MASSID_NULL_POINTER, "fixed push NULL rate");
    check(massid_fixed_flight_id_push(&fid, 0.0f, rate, 1, 0) == MASSID_OK, "fixed push");
    check(massid_fixed_flight_id_solve(&fid, &res) == MASSID_NO_DATA, "fixed solve without data");
}

static int read_hex_f32(const char *tok, float *out) {
    unsigned long b;
    char *end;
    uint32_t u;
    b = strtoul(tok, &end, 16);
    if (end == tok) return 0;
    u = (uint32_t)b;
    memcpy(out, &u, sizeof u);
    return 1;
}

/* Next whitespace-separated token of a line (strtok state). */
static const char *tok(char *line) { return strtok(line, " \t\r\n"); }
static const char *next_tok(void) { return strtok(NULL, " \t\r\n"); }

static int read_floats(float *v, int n) {
    for (int i = 0; i < n; i++) {
        const char *t = next_tok();
        if (!t || !read_hex_f32(t, &v[i])) return 0;
    }
    return 1;
}

/* Craft files written by tests/tests/capi.rs (every float as the hex of its bits):
 *   craft COUNT PLANAR DROP
 *   thruster PX PY PZ DX DY DZ THRUST      (COUNT lines)
 *   com Q24 Q24 Q24                        (--craft: CoM for the mixer, Q8.24 bits)
 *   cmd F0 F1 F2 T0 T1 T2                  (--craft: commands, Q8.24 bits)
 *   id INERTIA[6] COM[3] PERIOD            (--flight-id: nominal mass properties, period s)
 *   s DT R0 R1 R2 VALID WORD               (--flight-id: one sample) */
#define MAX_CMDS 256
/* flight_id: 0 mixer commands, 1 the f32 identification, 2 the integer-float one. */
static int run_craft_file(const char *path, int flight_id) {
    static massid_craft_mixer cm;
    static massid_flight_id id;
    static massid_fixed_flight_id fid;
    massid_craft c;
    int32_t com[3] = {0, 0, 0};
    static int32_t cmds[MAX_CMDS][6];
    int n_cmds = 0, n_thr = 0, have_id = 0;
    float inertia[6], id_com[3], period = 0.0f;
    char line[512];
    long line_no = 0, samples = 0;
    FILE *fp = fopen(path, "r");
    if (!fp) {
        fprintf(stderr, "%s: cannot open\n", path);
        return 1;
    }
    memset(&c, 0, sizeof c);
    while (fgets(line, sizeof line, fp)) {
        const char *k = tok(line);
        line_no++;
        if (!k) continue;
        if (strcmp(k, "craft") == 0) {
            const char *a = next_tok(), *b = next_tok(), *d = next_tok();
            if (!a || !b || !d || !read_hex_f32(d, &c.pressure_drop_n_per_extra)) goto bad;
            c.count = (uint32_t)strtoul(a, NULL, 10);
            c.planar = (uint32_t)strtoul(b, NULL, 10);
        } else if (strcmp(k, "thruster") == 0) {
            float v[7];
            if (n_thr >= MASSID_MAX_THRUSTERS || !read_floats(v, 7)) goto bad;
            for (int i = 0; i < 3; i++) {
                c.thruster_pos_m[n_thr][i] = v[i];
                c.thrust_dir[n_thr][i] = v[3 + i];
            }
            c.thrust_n[n_thr] = v[6];
            n_thr++;
        } else if (strcmp(k, "com") == 0) {
            for (int i = 0; i < 3; i++) {
                const char *t = next_tok();
                if (!t) goto bad;
                com[i] = (int32_t)strtol(t, NULL, 10);
            }
        } else if (strcmp(k, "cmd") == 0) {
            if (n_cmds >= MAX_CMDS) goto bad;
            for (int i = 0; i < 6; i++) {
                const char *t = next_tok();
                if (!t) goto bad;
                cmds[n_cmds][i] = (int32_t)strtol(t, NULL, 10);
            }
            n_cmds++;
        } else if (strcmp(k, "id") == 0) {
            massid_flight_id_settings st;
            massid_status s;
            if (!read_floats(inertia, 6) || !read_floats(id_com, 3) || !read_floats(&period, 1)) goto bad;
            s = massid_flight_id_settings_default(&c, inertia, id_com, period, &st);
            printf("settings status=%d", (int)s);
            print_hex_f32(st.scale, MASSID_ID_TERMS);
            printf(" window=%u turn_window=%u skip=%u turn", st.max_window, st.turn_window, st.skip);
            print_hex_f32(&st.max_window_turn_rad, 1);
            printf(" weight");
            print_hex_f32(st.turn_weight, 3);
            printf(" gyro=%d order=%d free ", st.gyroscopic, st.max_noise_order);
            print_flags(st.free, MASSID_ID_TERMS);
            printf(" axes ");
            print_flags(st.axes, 3);
            printf("\n");
            s = flight_id == 2 ? massid_fixed_flight_id_init(&fid, &c, &st) : massid_f32_flight_id_init(&id, &c, &st);
            printf("init status=%d\n", (int)s);
            if (s != MASSID_OK) {
                fclose(fp);
                return 1;
            }
            have_id = 1;
        } else if (strcmp(k, "s") == 0) {
            float v[4];
            const char *va, *w;
            if (!have_id || !read_floats(v, 4) || !(va = next_tok()) || !(w = next_tok())) goto bad;
            uint8_t valid = (uint8_t)strtoul(va, NULL, 10);
            uint16_t word = (uint16_t)strtoul(w, NULL, 10);
            if ((flight_id == 2 ? massid_fixed_flight_id_push(&fid, v[0], v + 1, valid, word)
                                : massid_f32_flight_id_push(&id, v[0], v + 1, valid, word)) != MASSID_OK)
                goto bad;
            samples++;
        } else {
            goto bad;
        }
    }
    fclose(fp);
    if (flight_id) {
        massid_flight_id_result r;
        massid_status s;
        if (!have_id) return 1;
        if (flight_id == 2) {
            massid_fixed_flight_id_finish(&fid);
            s = massid_fixed_flight_id_solve(&fid, &r);
        } else {
            massid_f32_flight_id_finish(&id);
            s = massid_f32_flight_id_solve(&id, &r);
        }
        printf("solve status=%d samples=%ld", (int)s, samples);
        if (s == MASSID_OK) {
            printf(" steps=%u pd=%d timing=%d", r.steps, r.positive_definite, r.has_timing_statistic);
            print_hex_f32(&r.timing_statistic, 1);
            printf(" symmetry ");
            print_flags(r.has_symmetry_statistic, 3);
            print_hex_f32(r.symmetry_statistic, 3);
            printf(" inconsistent=%d", massid_flight_id_inconsistent(&r));
            printf(" theta");
            print_hex_f32(r.theta, MASSID_ID_TERMS);
            printf(" held ");
            print_flags(r.held, MASSID_ID_TERMS);
            printf(" noise");
            for (int a = 0; a < 3; a++) {
                printf(" %d", r.noise_order[a]);
                print_hex_f32(r.noise_phi[a], MASSID_ID_MAX_NOISE_ORDER);
                print_hex_f32(&r.noise_sigma2[a], 1);
            }
            printf(" cov");
            for (int i = 0; i < MASSID_ID_TERMS; i++) print_hex_f32(r.covariance[i], MASSID_ID_TERMS);
        }
        printf("\n");
        return 0;
    }
    for (int flavour = 0; flavour < 2; flavour++) {
        const char *name = flavour == 0 ? "fixed" : "f32";
        float comf[3];
        uint8_t pairs = 0;
        massid_status s;
        for (int i = 0; i < 3; i++) comf[i] = CMD_F32(com[i]);
        s = flavour == 0 ? massid_fixed_craft_mixer_init(&cm, &c, com, PERIOD_MS, MIN_PULSE_MS)
                         : massid_f32_craft_mixer_init(&cm, &c, comf, PERIOD_MS, MIN_PULSE_MS);
        if (s == MASSID_OK) {
            s = flavour == 0 ? massid_fixed_craft_mixer_rule(&cm, &pairs) : massid_f32_craft_mixer_rule(&cm, &pairs);
        }
        printf("%s init status=%d pairs=%d\n", name, (int)s, pairs);
        if (s != MASSID_OK) continue;
        for (int k = 0; k < n_cmds; k++) {
            massid_craft_firing f;
            massid_status ms;
            if (flavour == 0) {
                ms = massid_fixed_craft_mix(&cm, cmds[k], cmds[k] + 3, &f);
            } else {
                float cf[6];
                for (int j = 0; j < 6; j++) cf[j] = CMD_F32(cmds[k][j]);
                ms = massid_f32_craft_mix(&cm, cf, cf + 3, &f);
            }
            printf("%s cmd%d status=%d on", name, k, (int)ms);
            for (int i = 0; i < MASSID_MAX_THRUSTERS; i++) printf(" %u", ms == MASSID_OK ? f.on_ms[i] : 0u);
            printf(" off");
            for (int i = 0; i < MASSID_MAX_THRUSTERS; i++) printf(" %u", ms == MASSID_OK ? f.off_ms[i] : 0u);
            printf("\n");
        }
    }
    return 0;
bad:
    fprintf(stderr, "%s:%ld: bad line\n", path, line_no);
    fclose(fp);
    return 1;
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
    if (argc == 3 && strcmp(argv[1], "--craft") == 0) return run_craft_file(argv[2], 0);
    if (argc == 3 && strcmp(argv[1], "--flight-id") == 0) return run_craft_file(argv[2], 1);
    if (argc == 3 && strcmp(argv[1], "--fixed-flight-id") == 0) return run_craft_file(argv[2], 2);
    if (argc == 3 && strcmp(argv[1], "--options") == 0) {
        g_opts = &OPTIONS;
        g_gaps_at_once = 1;
    } else if (argc != 2) {
        fprintf(stderr, "usage: capi_run --selftest | capi_run [--options] RECORDING.csv | capi_run --craft|--flight-id|--fixed-flight-id FILE\n");
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
