/*
 * massid_kernel.h - C ABI of the onboard mass-property identification kernel
 * (Rust crate massid-kernel, feature "capi"; static library built by kernel/capi-test/).
 *
 * Hand-written (small, stable surface); kernel/capi-test/capi_run.c checks every struct
 * size against massid_type_size() at run time, and the Rust side asserts at compile time
 * that the kernel's state fits the blocks declared here.
 *
 * Two instantiations with identical functions:
 *   massid_fixed_*  Q8.24 fixed point: every scalar crosses the ABI as int32_t raw bits,
 *                   value = bits / 2^24 (MASSID_Q24_ONE).
 *   massid_f32_*    IEEE single precision: float.
 *
 * The caller owns all memory (no allocation). Every function returns massid_status and
 * never aborts: NULL pointers, uninitialised state blocks and bad numbers become codes.
 * Typical use, in a 1 kHz interrupt:
 *
 *   static massid_pipeline p;            // once
 *   massid_satellite_params sp; massid_params_sph2(&sp);
 *   massid_fixed_init(&p, &sp, 1);
 *   ...
 *   massid_fixed_tick(&p, gyro_counts, thruster_word, &report);   // every sample
 *   if (report.event == MASSID_EVENT_SOLVED) massid_fixed_estimates(&p, &est);
 */
#ifndef MASSID_KERNEL_H
#define MASSID_KERNEL_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Version of this ABI, raised with every change of a struct's layout or a function's meaning.
 * Check massid_abi_version() == MASSID_ABI_VERSION before any other call: a library built
 * from another header then refuses instead of misreading a struct. History: 1 the first ABI,
 * 2 massid_flight_id_settings.turn_weight, 3 massid_flight_id_settings.thrust_sigma_rel,
 * 4 massid_flight_id_settings.rate_noise_ma_root and rate_noise_ma_lag, 5 massid_fixed_flight_id
 * 36864 bytes, 6 a 3-D craft's windows also end at the coupled noise walk (same layout, other
 * answers on fast-spinning craft). */
#define MASSID_ABI_VERSION 7u
uint32_t massid_abi_version(void);

#define MASSID_N_THRUSTERS 12
/* Bytes reserved for the opaque state blocks (kernel/src/capi.rs: PIPELINE_BYTES, MIXER_BYTES). */
#define MASSID_PIPELINE_BYTES 4096
#define MASSID_MIXER_BYTES 1024
/* Q8.24: value = bits / MASSID_Q24_ONE. */
#define MASSID_Q24_ONE 16777216

/* Status of every call. */
typedef enum massid_status {
    MASSID_OK = 0,
    MASSID_NULL_POINTER = 1,
    MASSID_NOT_INITIALISED = 2,
    MASSID_BAD_PARAMETERS = 3,
    MASSID_SINGULAR = 4,
    MASSID_OVERFLOW = 5,
    MASSID_BAD_COMMAND = 6,
    MASSID_PRESSURE_DROP_EXCEEDS_THRUST = 7,
    MASSID_OUT_OF_REACH = 8,         /* no non-negative firing gives the command's direction
                                        (or a planar craft was commanded Fz, Tx or Ty) */
    MASSID_NO_DATA = 9,              /* identification: no usable window yet */
    MASSID_NOT_CONVERGED = 10        /* identification: the fit did not settle */
} massid_status;

/* massid_tick_report.event */
enum {
    MASSID_EVENT_COASTING = 0,      /* thrusters off, nothing to do */
    MASSID_EVENT_TRANSIENT = 1,     /* inside the 10 ms valve transient */
    MASSID_EVENT_UPDATED = 2,       /* Kalman update (and an RLS measurement after the batch) */
    MASSID_EVENT_SOLVED = 3,        /* a firing ended and the estimate was re-solved */
    MASSID_EVENT_KF_OVERFLOW = 4,   /* the Kalman filter could not form an estimate: sample skipped */
    MASSID_EVENT_FIRING_TOO_LONG = 5,
    MASSID_EVENT_RAILED = 6         /* a gyro sample at a rail: the rest of the firing is unused */
};

/* Pipeline status codes (massid_tick_report.status, massid_estimates_*.status). */
enum {
    MASSID_PIPELINE_IDLE = 0,
    MASSID_PIPELINE_BATCH = 1,
    MASSID_PIPELINE_OK = 2,
    MASSID_PIPELINE_PARTLY_UNOBSERVABLE = 3,
    MASSID_PIPELINE_SINGULAR = 4,
    MASSID_PIPELINE_OVERFLOW = 5,
    MASSID_PIPELINE_IMPLAUSIBLE = 6 /* last solve not physical: previous estimate kept (see invalid) */
};

/* Why a solve was rejected (massid_estimates_*.invalid). */
enum {
    MASSID_VALID = 0,
    MASSID_INVALID_NOT_POSITIVE_DEFINITE = 1,
    MASSID_INVALID_TRIANGLE_INEQUALITY = 2,
    MASSID_INVALID_COM_OUTSIDE_ENVELOPE = 3
};

/* Satellite parameters (SI units unless named otherwise). */
typedef struct massid_satellite_params {
    float thruster_pos_m[MASSID_N_THRUSTERS][3]; /* from the geometric centre, m */
    float thrust_dir[MASSID_N_THRUSTERS][3];     /* force directions */
    float thrust_n[MASSID_N_THRUSTERS];          /* thrust strength, N */
    float inertia_kgm2[6];                       /* about the CoM: xx yy zz xy xz yz */
    float com_offset_mm[3];                      /* CoM minus geometric centre, mm */
    float gyro_counts_per_rad_s[3];
    float pressure_drop_n_per_extra;             /* N lost per extra open thruster */
} massid_satellite_params;

/* Pipeline options for massid_*_init_with (all zero: the seed's settings). */
typedef struct massid_options {
    uint8_t change_detector;     /* non-zero: CUSUM change detector on the RLS innovations */
    uint8_t gyroscopic;          /* non-zero: remove the gyroscopic acceleration (needs the bias) */
    float gyro_bias_counts[3];   /* gyro zero-rate counts per axis */
    float forgetting;            /* forgetting factor per update in (0,1); 0 or 1: none */
} massid_options;

typedef struct massid_tick_report {
    uint8_t event;  /* MASSID_EVENT_* */
    uint8_t status; /* MASSID_PIPELINE_* */
} massid_tick_report;

/* Estimates, fixed point (Q8.24 bits). */
typedef struct massid_estimates_fixed {
    int32_t delta_com_m[3];          /* CoM offset from the model's CoM, m */
    int32_t theta_inertia[6];        /* inverse inertia xx yy zz xy xz yz, 1/(kg m^2)/100 */
    uint8_t unobservable_com[3];     /* non-zero: held at the model */
    uint8_t unobservable_inertia[6];
    uint8_t status;                  /* MASSID_PIPELINE_* */
    uint32_t updates;
    uint32_t firings;
    uint32_t resets;
    uint8_t invalid;                 /* MASSID_VALID or MASSID_INVALID_* */
    uint32_t railed_samples;         /* gyro samples at a rail */
    uint32_t railed_firings;         /* firings cut short at a railed sample */
    uint32_t unresponsive_firings;   /* firings with no gyro response: not fitted */
} massid_estimates_fixed;

/* Estimates, f32. */
typedef struct massid_estimates_f32 {
    float delta_com_m[3];
    float theta_inertia[6];
    uint8_t unobservable_com[3];
    uint8_t unobservable_inertia[6];
    uint8_t status;
    uint32_t updates;
    uint32_t firings;
    uint32_t resets;
    uint8_t invalid;
    uint32_t railed_samples;
    uint32_t railed_firings;
    uint32_t unresponsive_firings;
} massid_estimates_f32;

/* ON/OFF times of one control period, ms from the period start (on == off == 0: off). */
typedef struct massid_firing {
    uint32_t on_ms[MASSID_N_THRUSTERS];
    uint32_t off_ms[MASSID_N_THRUSTERS];
} massid_firing;

/* Opaque state blocks: declare them statically; initialise with the *_init functions. */
typedef struct massid_pipeline {
    uint64_t opaque[MASSID_PIPELINE_BYTES / 8];
} massid_pipeline;

typedef struct massid_mixer {
    uint64_t opaque[MASSID_MIXER_BYTES / 8];
} massid_mixer;

/* Built-in SPH2 parameters (seed App. C). */
massid_status massid_params_sph2(massid_satellite_params *out);

/* Layout checks: size of an ABI type as Rust lays it out (0 params, 1 tick report,
 * 2 fixed estimates, 3 f32 estimates, 4 firing, 5 pipeline block, 6 mixer block, 7 options). */
uint32_t massid_type_size(uint32_t which);
/* Bytes of the kernel state inside a block (fixed_point != 0: Q8.24, else f32). */
uint32_t massid_pipeline_state_bytes(uint8_t fixed_point);
uint32_t massid_mixer_state_bytes(uint8_t fixed_point);

/* ---- fixed point (Q8.24) ---- */
massid_status massid_fixed_init(massid_pipeline *p, const massid_satellite_params *params,
                                uint32_t sample_period_ms);
massid_status massid_fixed_init_with(massid_pipeline *p, const massid_satellite_params *params,
                                     uint32_t sample_period_ms,
                                     const massid_options *options /* NULL: seed settings */);
massid_status massid_fixed_tick(massid_pipeline *p, const uint16_t gyro_counts[3],
                                uint16_t thrusters, massid_tick_report *report /* may be NULL */);
massid_status massid_fixed_tick_gap(massid_pipeline *p, massid_tick_report *report);
/* `periods` sample periods without a sample, in O(1). */
massid_status massid_fixed_tick_gaps(massid_pipeline *p, uint64_t periods, massid_tick_report *report);
massid_status massid_fixed_finish(massid_pipeline *p, uint8_t *status /* may be NULL */);
massid_status massid_fixed_estimates(massid_pipeline *p, massid_estimates_fixed *out);
massid_status massid_fixed_mixer_init(massid_mixer *m, const massid_satellite_params *params,
                                      const int32_t com_delta_m[3] /* NULL: model CoM */,
                                      uint32_t period_ms, uint32_t min_pulse_ms);
massid_status massid_fixed_mixer_from_pipeline(massid_mixer *m, const massid_satellite_params *params,
                                               massid_pipeline *p, uint32_t period_ms,
                                               uint32_t min_pulse_ms);
massid_status massid_fixed_mix(massid_mixer *m, const int32_t force_n[3], const int32_t torque_nm[3],
                               massid_firing *out);

/* ---- f32 ---- */
massid_status massid_f32_init(massid_pipeline *p, const massid_satellite_params *params,
                              uint32_t sample_period_ms);
massid_status massid_f32_init_with(massid_pipeline *p, const massid_satellite_params *params,
                                   uint32_t sample_period_ms, const massid_options *options);
massid_status massid_f32_tick(massid_pipeline *p, const uint16_t gyro_counts[3],
                              uint16_t thrusters, massid_tick_report *report);
massid_status massid_f32_tick_gap(massid_pipeline *p, massid_tick_report *report);
massid_status massid_f32_tick_gaps(massid_pipeline *p, uint64_t periods, massid_tick_report *report);
massid_status massid_f32_finish(massid_pipeline *p, uint8_t *status);
massid_status massid_f32_estimates(massid_pipeline *p, massid_estimates_f32 *out);
massid_status massid_f32_mixer_init(massid_mixer *m, const massid_satellite_params *params,
                                    const float com_delta_m[3], uint32_t period_ms,
                                    uint32_t min_pulse_ms);
massid_status massid_f32_mixer_from_pipeline(massid_mixer *m, const massid_satellite_params *params,
                                             massid_pipeline *p, uint32_t period_ms,
                                             uint32_t min_pulse_ms);
massid_status massid_f32_mix(massid_mixer *m, const float force_n[3], const float torque_nm[3],
                             massid_firing *out);

/* ==== Any craft: 1-16 thrusters, 3-D or planar (kernel/src/capi/craft.rs) ==== */

#define MASSID_MAX_THRUSTERS 16
/* Bytes reserved for the opaque blocks (capi/craft.rs: CRAFT_MIXER_BYTES, FLIGHT_ID_BYTES,
 * FIXED_FLIGHT_ID_BYTES). */
#define MASSID_CRAFT_MIXER_BYTES 2048
#define MASSID_FLIGHT_ID_BYTES 20480
#define MASSID_FIXED_FLIGHT_ID_BYTES 36864
/* Terms of the identification: inverse inertia xx yy zz xy xz yz, CoM x y z. */
#define MASSID_ID_TERMS 9
#define MASSID_ID_MAX_NOISE_ORDER 2

/* A craft's thruster table: `count` thrusters in the first slots, the rest ignored. */
typedef struct massid_craft {
    uint32_t count;                                  /* 1-16 */
    uint32_t planar;                                 /* non-zero: air-bearing (Fx Fy Tz only) */
    float thruster_pos_m[MASSID_MAX_THRUSTERS][3];   /* from the geometric centre, m */
    float thrust_dir[MASSID_MAX_THRUSTERS][3];       /* force directions (unit) */
    float thrust_n[MASSID_MAX_THRUSTERS];            /* thrust, N (> 0) */
    float pressure_drop_n_per_extra;                 /* N lost per extra open thruster (>= 0) */
} massid_craft;

/* ON/OFF times per thruster slot, ms from the period start (on == off == 0: off). */
typedef struct massid_craft_firing {
    uint32_t on_ms[MASSID_MAX_THRUSTERS];
    uint32_t off_ms[MASSID_MAX_THRUSTERS];
} massid_craft_firing;

typedef struct massid_craft_mixer {
    uint64_t opaque[MASSID_CRAFT_MIXER_BYTES / 8];
} massid_craft_mixer;

typedef struct massid_flight_id {
    uint64_t opaque[MASSID_FLIGHT_ID_BYTES / 8];
} massid_flight_id;

/* The identification in the integer float (targets without an FPU): a larger block. */
typedef struct massid_fixed_flight_id {
    uint64_t opaque[MASSID_FIXED_FLIGHT_ID_BYTES / 8];
} massid_fixed_flight_id;

/* Identification settings (massid_flight_id_settings_default fills the ground tool's). */
typedef struct massid_flight_id_settings {
    float inertia_kgm2[6];        /* nominal, about the CoM: xx yy zz xy xz yz */
    float com_m[3];               /* the model's CoM from the geometric centre, m */
    float period_s;               /* nominal sample period; a step over 1.5 of it starts a window */
    float delay_periods;          /* known command-to-thrust delay, sample periods */
    float rate_noise_ma_root;     /* the rate noise's moving-average root, [0, 0.99] (0: a gyro; the noise's ma that massid estimate reports for an earlier flight, negated) */
    float max_window_turn_rad;    /* past turn_window samples, cut a window after this weighted turn (INFINITY: never); a 3-D craft's window also ends at the coupled noise walk, whatever its length (flight_id::window) */
    float turn_weight[3];         /* per axis, how much its turn counts: finite, > 0 (1 for SPHERES-like coupling) */
    float scale[MASSID_ID_TERMS]; /* per term, the standard error beyond which it is held */
    float thrust_sigma_rel[MASSID_MAX_THRUSTERS]; /* per thruster, relative thrust uncertainty (0: known) */
    uint32_t max_window;          /* samples */
    uint32_t turn_window;         /* samples */
    uint32_t skip;                /* samples left out at each window start (= max_noise_order) */
    uint8_t sensor;               /* 0 gyro (point), 1 backward mean, 2 central mean */
    uint8_t cut_at_changes;       /* non-zero: cut windows where the acting wrench changes */
    uint8_t gyroscopic;           /* non-zero: Euler's gyroscopic term (3-D craft) */
    uint8_t max_noise_order;      /* 0-2 */
    uint8_t rate_noise_ma_lag;    /* 1 (attitude differenced over one sample) or 2 (central difference): massid estimate's ma_lag */
    uint8_t free[MASSID_ID_TERMS];/* non-zero: the fit may move the term */
    uint8_t axes[3];              /* non-zero: the axis' rate enters the fit */
} massid_flight_id_settings;

/* Identification result (f32). */
typedef struct massid_flight_id_result {
    float theta[MASSID_ID_TERMS];   /* inverse inertia 1/(kg m^2), then CoM minus settings.com_m, m */
    float covariance[MASSID_ID_TERMS][MASSID_ID_TERMS];
    float noise_phi[3][MASSID_ID_MAX_NOISE_ORDER];   /* per axis AR coefficients */
    float noise_sigma2[3];          /* per axis innovation variance, (rad/s)^2 */
    float timing_statistic;         /* chi-square (1 dof) of a command delay, if has_timing_statistic */
    float symmetry_statistic[3];    /* per torque axis, chi-square (1 dof) of a thrust asymmetry, if has_symmetry_statistic */
    uint32_t steps;                 /* Gauss-Newton steps */
    uint8_t held[MASSID_ID_TERMS];  /* non-zero: held at the nominal */
    uint8_t noise_order[3];
    uint8_t positive_definite;
    uint8_t has_timing_statistic;
    uint8_t has_symmetry_statistic[3]; /* per axis, non-zero: symmetry_statistic is set */
} massid_flight_id_result;

/* Layout checks (0 craft, 1 craft firing, 2 craft mixer block, 3 flight_id block,
 * 4 flight_id settings, 5 flight_id result, 6 fixed flight_id block). */
uint32_t massid_craft_type_size(uint32_t which);
/* Kernel state inside a block: 1 fixed craft mixer, 0 f32 craft mixer, 2 identification,
 * 3 integer-float identification. */
uint32_t massid_craft_state_bytes(uint8_t which);
/* The SPHERES parameters as a craft (12 thrusters, 3-D). */
massid_status massid_craft_from_params(const massid_satellite_params *params, massid_craft *out);

/* Craft mixer: SPHERES' layout gets the seed's pair rules, any other craft the smallest
 * non-negative duties; com_m = CoM from the geometric centre, m (NULL: the centre). */
massid_status massid_fixed_craft_mixer_init(massid_craft_mixer *m, const massid_craft *craft,
                                            const int32_t com_m[3], uint32_t period_ms,
                                            uint32_t min_pulse_ms);
massid_status massid_fixed_craft_mix(massid_craft_mixer *m, const int32_t force_n[3],
                                     const int32_t torque_nm[3], massid_craft_firing *out);
massid_status massid_fixed_craft_mixer_rule(massid_craft_mixer *m, uint8_t *opposing_pairs);
massid_status massid_f32_craft_mixer_init(massid_craft_mixer *m, const massid_craft *craft,
                                          const float com_m[3], uint32_t period_ms,
                                          uint32_t min_pulse_ms);
massid_status massid_f32_craft_mix(massid_craft_mixer *m, const float force_n[3],
                                   const float torque_nm[3], massid_craft_firing *out);
massid_status massid_f32_craft_mixer_rule(massid_craft_mixer *m, uint8_t *opposing_pairs);

/* Identification from any flight, in f32 (massid_f32_*) or in the integer float
 * (massid_fixed_*: integer instructions; same settings, samples and f32 result). */
massid_status massid_flight_id_settings_default(const massid_craft *craft, const float inertia_kgm2[6],
                                                const float com_m[3], float period_s,
                                                massid_flight_id_settings *out);
massid_status massid_f32_flight_id_init(massid_flight_id *id, const massid_craft *craft,
                                        const massid_flight_id_settings *settings);
/* One sample: dt since the previous one, body rate rad/s, valid (0: missing/railed), and the
 * thruster word (bit i = thruster i+1) or body wrench (torque N m about the model CoM, force N)
 * commanded from this sample on. Prefer the word: from a wrench the kernel cannot tell two
 * thrusters turning the craft opposite ways and fired together from neither firing, which the
 * stated thrust uncertainty's sigma and the thrust-symmetry test then miss. */
massid_status massid_f32_flight_id_push(massid_flight_id *id, float dt_s, const float rate_rad_s[3],
                                        uint8_t valid, uint16_t thrusters);
massid_status massid_f32_flight_id_push_wrench(massid_flight_id *id, float dt_s,
                                               const float rate_rad_s[3], uint8_t valid,
                                               const float wrench[6]);
massid_status massid_f32_flight_id_finish(massid_flight_id *id);
/* Outside the tick (copies the sums: 21,728 bytes of stack on the M4F, 22,160 on the M0).
 * Never while a push on the same block can run (mask it, or push into a second block). */
massid_status massid_f32_flight_id_solve(massid_flight_id *id, massid_flight_id_result *out);
/* Moves the f32 sums' reference model to a solve's theta (9 floats, the result's theta), so
 * that f32 keeps its precision on a craft far from the configured model: exact (solves before
 * and after agree up to rounding). Outside the tick, as the solve. A caller solves and
 * re-anchors now and then (the ground tool: after 1,024 samples and at each doubling).
 * MASSID_SINGULAR, MASSID_OVERFLOW: nothing changed. No integer-float form (its sums are exact). */
massid_status massid_f32_flight_id_reanchor(massid_flight_id *id, const float theta[9]);
/* The integer-float form keeps its per-sample sums as exact integers scaled to the craft: a
 * wrench 2-4 times beyond its thrusters' (push_wrench) or a rate 2-4 times beyond one turn a
 * second (2 pi rad/s) makes its solve answer MASSID_OVERFLOW rather than a rounded wrong sum;
 * init refuses (MASSID_BAD_PARAMETERS) windows of more than 100 s of reach (max_window steps of
 * 1.5 periods), whose resolution would be too coarse. */
massid_status massid_fixed_flight_id_init(massid_fixed_flight_id *id, const massid_craft *craft,
                                          const massid_flight_id_settings *settings);
massid_status massid_fixed_flight_id_push(massid_fixed_flight_id *id, float dt_s,
                                          const float rate_rad_s[3], uint8_t valid,
                                          uint16_t thrusters);
massid_status massid_fixed_flight_id_push_wrench(massid_fixed_flight_id *id, float dt_s,
                                                 const float rate_rad_s[3], uint8_t valid,
                                                 const float wrench[6]);
massid_status massid_fixed_flight_id_finish(massid_fixed_flight_id *id);
/* Outside the tick (45,732 bytes of stack on the M4F, 46,792 on the M0); as above, never
 * while a push on the same block can run. */
massid_status massid_fixed_flight_id_solve(massid_fixed_flight_id *id, massid_flight_id_result *out);
/* 1 if the result's consistency tests reject the model (timing, or any axis' thrust symmetry):
 * the estimate is then inconsistent, not to be vouched for; 0 if not; 1 for NULL. Sized for a
 * gyro (sensor 0): for rates differenced from attitude the tests are not applied. */
uint8_t massid_flight_id_inconsistent(const massid_flight_id_result *result);

#ifdef __cplusplus
}
#endif

#endif /* MASSID_KERNEL_H */
