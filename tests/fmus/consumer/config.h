/*
 * config.h -- "CoolingConsumer", a test FMU in the shape of a third-party export
 * (an OpenModelica test model of a cooling consumer): six inputs that declare no
 * min or max, some with units (Pa, K, W) and start values, one with start 0 K as
 * exporters write for an input the model gives no start; a default experiment
 * of 1 s in 2 ms steps, far shorter than the model's time constants. A chilled
 * water coil cools a room through a valve:
 *
 *   der(opening) = (clamp(valve, 0, 1) - opening) / tau_valve      (10 s)
 *   m_flow = Kv opening sqrt(max(p_supply - p_return, 0))
 *   Q_flow = (1 - exp(-UA / (m_flow cp))) m_flow cp (T_room - T_supply)
 *   T_return = T_supply + Q_flow / (m_flow cp)     (T_room without flow)
 *   C_room der(T_room) = Q_gain + G (T_amb - T_room) - Q_flow,  T_room(0) = T_room_0
 *
 *   inputs   valve (the command, no unit), p_supply, p_return (Pa), T_supply,
 *            T_amb (K; T_amb starts at 0 K), Q_gain (W)
 *   outputs  T_room, T_return (K), m_flow (kg/s), Q_flow (W)
 *
 * Like the model it stands for, it computes silently whatever its inputs are
 * (a negative pressure difference gives no flow, 0 K outside a freezing room).
 */
#ifndef COOLING_CONSUMER_CONFIG_H
#define COOLING_CONSUMER_CONFIG_H

#define NX 2 /* opening, T_room */
#define NZ 0
#define CP_WATER 4186.0 /* J/(kg K) */
#define KV 2e-3         /* kg/s per sqrt(Pa) at full opening */
#define G_WALLS 200.0   /* W/K */
#define TAU_VALVE 10.0  /* s */

enum {
    VR_T_ROOM = 1, VR_DER_T_ROOM = 2, VR_OPENING = 3, VR_DER_OPENING = 4,
    VR_VALVE = 5, VR_P_SUPPLY = 6, VR_P_RETURN = 7, VR_T_SUPPLY = 8, VR_T_AMB = 9, VR_Q_GAIN = 10,
    VR_T_RETURN = 11, VR_M_FLOW = 12, VR_Q_FLOW = 13,
    VR_C_ROOM = 14, VR_UA = 15, VR_T_ROOM_0 = 16
};

typedef struct {
    double T_room, der_T_room, opening, der_opening;
    double valve, p_supply, p_return, T_supply, T_amb, Q_gain;
    double T_return, m_flow, Q_flow;
    double C_room, UA, T_room_0;
} ModelData;

#endif /* COOLING_CONSUMER_CONFIG_H */
