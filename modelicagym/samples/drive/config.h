/*
 * config.h -- "TwoMassDrive", the sample FMU of `modelicagym sample drive`: a motor
 * turning a load through an elastic shaft, the motor's speed to be controlled.
 *
 *   der(phiA) = wA,   J_A der(wA) = M_A - M_c,
 *   der(phiB) = wB,   J_B der(wB) = M_B + M_c,
 *   M_c = c (phiA - phiB) + d (wA - wB)          the torque the shaft passes on
 *
 *   inputs  M_A    the motor's torque (N.m), -2..2
 *           M_B    a torque on the load (N.m): negative brakes it
 *   outputs wA, phiA   the motor's speed (rad/s) and angle (rad), states
 *           wB, phiB   the load's speed (rad/s) and angle (rad), states
 *   parameters J_A, J_B (kg.m2), c (N.m/rad), d (N.m.s/rad)
 *
 * Nothing holds the drive but its torques (no friction to ground): a constant
 * torque accelerates it without end, and a controller that holds a speed must
 * balance the load. The defaults (J_A + J_B = 0.015 kg.m2, the shaft's
 * resonance near 9 Hz) let the motor's full torque bring the drive from rest to
 * 200 rad/s in about 1.5 s.
 */
#ifndef TWO_MASS_DRIVE_CONFIG_H
#define TWO_MASS_DRIVE_CONFIG_H

#define NX 4 /* phiA, wA, phiB, wB */
#define NZ 0

enum { VR_PHI_A = 1, VR_W_A = 2, VR_PHI_B = 3, VR_W_B = 4, VR_DER_PHI_A = 5, VR_DER_W_A = 6, VR_DER_PHI_B = 7,
       VR_DER_W_B = 8, VR_M_A = 9, VR_M_B = 10, VR_J_A = 11, VR_J_B = 12, VR_C = 13, VR_D = 14 };

typedef struct {
    double phiA, wA, phiB, wB;
    double der_phiA, der_wA, der_phiB, der_wB;
    double M_A, M_B;
    double J_A, J_B, c, d;
} ModelData;

#endif /* TWO_MASS_DRIVE_CONFIG_H */
