/*
 * config.h -- "RoomHeater", the sample FMU of `modelicagym sample heater` and of
 * the walkthrough "Train on your own FMU" (examples/train_own_fmu.py): a room's
 * air heated by an electric heater and cooled through its walls, a first-order lag.
 *
 *   C der(T) = P - G (T - T_amb),   P = P_max clamp(u, 0, 1),   T(0) = T_0
 *
 *   input   u      heater command, 0..1 (a saturating actuator: outside [0, 1]
 *                  it heats as at the nearest end)
 *   outputs T      room temperature (degC), the state
 *           P      heating power (W)
 *   parameters C (J/K), G (W/K), P_max (W), T_amb (degC), T_0 (degC)
 *
 * The defaults (the air of a 50 m3 room: C = 6e4 J/K; walls G = 100 W/K; a
 * 3 kW heater; 5 degC outside) give a time constant C / G = 600 s: ten steps of
 * the default 60 s, so holding a setpoint is a task an agent learns in a few
 * thousand steps. Full power settles at T_amb + P_max / G = 35 degC.
 */
#ifndef ROOM_HEATER_CONFIG_H
#define ROOM_HEATER_CONFIG_H

#define NX 1 /* T */
#define NZ 0

enum { VR_T = 1, VR_DER_T = 2, VR_U = 3, VR_P = 4, VR_C = 5, VR_G = 6, VR_P_MAX = 7, VR_T_AMB = 8, VR_T_0 = 9 };

typedef struct {
    double T, der_T;
    double u, P;
    double C, G, P_max, T_amb, T_0;
} ModelData;

#endif /* ROOM_HEATER_CONFIG_H */
