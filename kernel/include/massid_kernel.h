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
    MASSID_OUT_OF_REACH = 8          /* no non-negative firing gives the command's direction
                                        (or a planar craft was commanded Fz, Tx or Ty) */
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

#ifdef __cplusplus
}
#endif

#endif /* MASSID_KERNEL_H */
