/* accuracy_private.h — a rule of ndo_acc_choose (accuracy.c) that its test
 * checks directly (not installed): the pilots of a real scene seldom reach
 * the case it decides. */
#ifndef NDO_ACCURACY_PRIVATE_H
#define NDO_ACCURACY_PRIVATE_H

/* The time error a candidate level may add to its space error es (m) for
 * a target of target_m metres: margin × target_m − es, the margin 0.7
 * where the level was measured (a pilot's level), 0.5 where predicted.
 * When that is not positive, the input's level (input: 1), which has no
 * finer alternative, may take half of what the target leaves,
 * 0.5 × (target_m − es); a coarser level may not: a finer one fits the
 * margin.  ≤ 0: not a candidate. */
double ndo__acc_budget(double target_m, double es, int measured, int input);

#endif
