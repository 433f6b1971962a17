"""The search's defaults that command-line options show (`planner.search.gait_search` uses them):
a module of its own so that declaring the options does not import the search (issue #16)."""

from __future__ import annotations

#: Weight of the support term (cost units per unit of open-loop error amplification). A
#: template trot at quad12's default period (two 0.19 s line phases, amplification 2.1) pays
#: 0.11, about half the spacetime cost of a trot at 0.25 m/s.
DEFAULT_TIPPING_WEIGHT = 0.05
#: Coarse NLP of the search (see `planner.search.gait_search`) and the final solves it hands on.
DEFAULT_SEARCH_KNOTS = 12
#: basin-CMA generations of a search (`gaitsmith plan --search --generations`, `gaitsmith sweep`)
DEFAULT_GENERATIONS = 6
#: How the final phase picks among the timings it re-solves at full resolution
#: (`planner.search.final_phase.choose_final`): the first accepted in coarse rank order; the
#: accepted one cheapest at full resolution among the first two (the second is the one a
#: two-worker pool solves beside the first anyway); or among all of them.
FINAL_CHOICE_FIRST = "first"
FINAL_CHOICE_CHEAPEST_OF_2 = "cheapest-of-2"
FINAL_CHOICE_CHEAPEST = "cheapest"
FINAL_CHOICES = (FINAL_CHOICE_FIRST, FINAL_CHOICE_CHEAPEST_OF_2, FINAL_CHOICE_CHEAPEST)
#: "cheapest-of-2": over 29 replayed searches on 8 bodies a cheaper gait in 4 (−1.7 … −8.4 %),
#: none costlier; the README command reads the same candidates as "first" (its first two fail at
#: 30 knots); where it reads a second candidate it cost 0.86–1.10× the CPU on hex18 and
#: phantomx18 (docs/results/planner_speed_search.md, session 35 (lead)). "cheapest" (all of
#: them): 6 of 29 cheaper, but the README command 1.26–1.38× the CPU.
DEFAULT_FINAL_CHOICE = FINAL_CHOICE_CHEAPEST_OF_2
#: Whether the templates the search started from are re-solved only when no searched timing
#: passes at full resolution ("fallback"), or also compete with an accepted winner ("compete":
#: every template whose coarse plan solved is re-solved, the cheapest accepted one wins if it is
#: cheaper, cost + support term; `planner.search.final_phase.choose_final(rival=)`).
FINAL_TEMPLATES_FALLBACK = "fallback"
FINAL_TEMPLATES_COMPETE = "compete"
FINAL_TEMPLATES = (FINAL_TEMPLATES_FALLBACK, FINAL_TEMPLATES_COMPETE)
#: "compete" over 32 replayed searches on 8 bodies: 1 cheaper gait (−2 %), none costlier, at
#: 1.10× the CPU; on half-cycle coarse searches the worst outcome 5.1× → 2.5× of full-cycle
#: ones (docs/results/planner_speed_search.md, session 37 (lead)). The default since session 38,
#: with `SEARCH_HALF_CYCLE`: the floor that makes the cheaper half-cycle search safe (session 38
#: (lead)).
DEFAULT_FINAL_TEMPLATES = FINAL_TEMPLATES_COMPETE
#: `PlannerOptions.inactive_rows` of the search's coarse solves, whatever the final solves use:
#: at N = 12 "free" ended on another local optimum on 2 of 35 quad12/hex18 schedules
#: (docs/results/planner_speed_ipopt.md, session 33, branch rank)
SEARCH_INACTIVE_ROWS = "rows"
#: `PlannerOptions.stance_clearance` of the search's coarse solves, whatever the final solves
#: use: "rows", as the searches of docs/results were measured (a changed projection changes
#: CMA's course; "free" was measured at N = 30 only, planner_speed_coldstart.md, session 39)
SEARCH_STANCE_CLEARANCE = "rows"
#: `PlannerOptions.cold_mu_centrality` of the search's coarse solves, whatever the final solves
#: use: "none", as the searches of docs/results were measured (planner_speed_coldstart.md,
#: session 39: measured at N = 30 only)
SEARCH_COLD_MU_CENTRALITY = "none"
#: `PlannerOptions.half_cycle_solve` of the search's coarse solves: a symmetric sample (every
#: sample of a symmetric timing space, straight) is solved on the first half of its knots
#: (`planner.nlp.half_cycle`); the final re-solves take `FINAL_HALF_CYCLE`. On since session 38
#: with "compete" (`DEFAULT_FINAL_TEMPLATES`): real runs of 32 searches on 8 bodies wrote gaits
#: whose cost + support term is 0.995× the full-cycle search's, unpaired [0.92, 1.08] (the
#: seeds are draws), 32 of 32 passing, at 0.66× the CPU; the courses part as a seed change parts
#: them (paired |log ratio| 90th percentile 1.46, seed to seed 1.46); the README search 0.51×
#: the CPU, the same trot (docs/results/planner_speed_search.md, sessions 36, 37, 38 (lead))
SEARCH_HALF_CYCLE = True
#: `PlannerOptions.half_cycle_solve` of the search's final re-solves of its candidates
#: (`search_gait(final_half_cycle=)`), whatever the options say (`PlannerOptions`' own default
#: is on, for the template path; the templates the final phase re-solves are planned as the
#: template path plans them, with the options' own: `final_tasks(template_half_cycle=)`, session
#: 38). On since session 40 (was off), with `FINAL_RETRY_FULL` "narrow": over the 32 searches of
#: session 38, exact replays wrote the same gait, cost and verdict as the full-cycle re-solves in
#: 32 of 32 at **0.70× the final phase's CPU** (314 against 452 CPU-s; the retry fired 3 times
#: and rescued bittle8 seed 3's trot, whose half plan misses the heading limit by 0.16 %); real
#: runs the same 32 of 32 against session 38's rows (geometric mean 1.0000, p90 |log ratio|
#: 1.000), the search ≈ 0.92× the CPU; the README search 0.92× the CPU, the same trot
#: (docs/results/planner_speed_search.md, session 40 (branch narrowretry)). Before: "halffinal"
#: (no retry) 0.70× but lost that trot (2.17× the cost, 36-lead i, session 39); "halfretry"
#: (every failure retried) kept it but at 1.11× the final phase's CPU (session 39 (branch
#: robustfinal)).
FINAL_HALF_CYCLE = True
#: `search_gait(final_retry_full=)`: which candidates whose final re-solve ran on half the
#: knots (`FINAL_HALF_CYCLE`) and did not pass are re-solved cold on the full NLP, that plan
#: judged instead (`planner.search.final_phase.evaluate_final`): "all" — every infeasible or
#: failing one (session 39 (branch robustfinal), "halfretry"); "narrow" — only a feasible plan
#: that fails the final check narrowly, every failed criterion's metric within
#: `FINAL_RETRY_MARGIN` of its limit (`final_phase.narrow_failure`; session 40 (branch
#: narrowretry)); "off" — none. One task either way, so the final rule and its reading order
#: are unchanged; the templates are not retried (they are planned as the template path plans
#: them). No effect with the full-cycle re-solves.
#: "all" (session 39 (lead), `benchmarks/retry_points.py`, 41 replayed retries) landed on the
#: half plan's own point in 15, the same optimum to < 1e-3 in 15, another point or infeasible
#: in 11; its one rescue (bittle8 seed 3) was the same plan to 6.5e-6 judged again — a
#: knife-edge MuJoCo verdict — and none of the infeasible or other-point retries passed.
FINAL_RETRY_ALL = "all"
FINAL_RETRY_NARROW = "narrow"
FINAL_RETRY_OFF = "off"
FINAL_RETRIES = (FINAL_RETRY_ALL, FINAL_RETRY_NARROW, FINAL_RETRY_OFF)
#: "narrow" since session 40 (was "all", which only mattered with `--half-cycle`): 3 retries
#: instead of 47 over the 32 searches, the same gaits (`FINAL_HALF_CYCLE`).
FINAL_RETRY_FULL = FINAL_RETRY_NARROW
#: "narrow": a failed criterion counts as narrow when its metric is at most this far past its
#: limit, relative to the limit (`sim.validate.criterion_excess`: 0.05 is a heading error of
#: 5.25° against 5°, a speed 10.5 % off against ±10 %); a fall is never narrow. Chosen from the
#: 41 retries of session 39 (planner_speed_search.md, 40-a): the one rescue failed by 0.16 %;
#: failures at 1.8 % and 4.1 % were re-solved to a point whose metric moved (both still failed);
#: those at 5.2 % and 8.5 % were re-solved to the identical point (the same verdict again), one
#: at 8.4 % failed again, and every other failure was ≥ 12 % past a limit, a fall or
#: infeasible. Not validated beyond them.
FINAL_RETRY_MARGIN = 0.05
#: `PlannerOptions.swing_wrench` of the search's coarse solves (`search_gait(search_swing_wrench=)`,
#: `plan --search --search-swing-wrench`) and of the final re-solves of its candidates
#: (`search_gait(final_swing_wrench=)`, `--final-swing-wrench`), whatever the options say (None:
#: the options' own); the templates the final phase re-solves keep the options' own (the template
#: path's: "rows" until session 42, `planner.nlp.config.DEFAULT_SWING_WRENCH` "bounds" since),
#: so a rival is the template command's plan. "bounds" (the swing feet's
#: wrench fixed to 0 by its bounds, `planner.nlp.swing_wrench`) for both since session 40:
#: over the 32 searches on 8 bodies of session 38, run back to back with "rows", 32 of 32 pass,
#: the written cost + support term 0.951x paired geometric mean (19 the same, 7 cheaper by
#: 9-59 %, 6 costlier by 0.1-3.1 %; paired |log ratio| 90th percentile 1.14, seed to seed
#: 1.46), 0.83x the coarse iterations and 0.88x the CPU; the README search 1.00-1.01x the CPU,
#: the same trot. Coarse "bounds" with "rows" finals cost that command 1.09-1.11x (its final
#: phase reads 8 outcomes instead of 6), which kept it off in session 32
#: (docs/results/planner_speed_search.md, sessions 32 and 40).
SEARCH_SWING_WRENCH = "bounds"
FINAL_SWING_WRENCH = "bounds"
