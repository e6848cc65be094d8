/*
 * fmu_internal.h -- helpers shared by fmu_instance.c and fmu_solver.c; not part
 * of the adapters' API (fmu_instance.h) nor of the model contract (model.h).
 */
#ifndef MODELICAGYM_FMU_INTERNAL_H
#define MODELICAGYM_FMU_INTERNAL_H

#include "fmu_instance.h"

/* Interface states in which the model's values are initialized (a Mode mask). */
#define MODES_INITIALIZED \
    (ModeInitialization | ModeEvent | ModeContinuousTime | ModeStep | ModeTerminated)

/* Log an error (category logStatusError) and return StatusError. */
Status fmu_fail(ModelInstance *comp, const char *format, ...) FMU_PRINTF_FORMAT(2, 3);

/* True if the instance is in one of `modes`; otherwise log that `function` is not allowed. */
bool fmu_allowed(ModelInstance *comp, const char *function, unsigned modes);

/* Bring calculated values up to date (initialize + calculate_values hooks) before a read. */
Status fmu_update_values(ModelInstance *comp);

/* Co-simulation: event updates until the model needs no more (also after initialization). */
Status fmu_cs_event_iteration(ModelInstance *comp);

#endif /* MODELICAGYM_FMU_INTERNAL_H */
