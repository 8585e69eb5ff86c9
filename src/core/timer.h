#ifndef SM_CORE_TIMER_H
#define SM_CORE_TIMER_H
/* Monotonic wall clock in seconds. */
double sm_seconds(void);
#endif
