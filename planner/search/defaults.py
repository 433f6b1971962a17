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
#: 38): "halffinal" read the same
#: verdict on 35 of 35 candidates in 12 exact replays at 0.26–0.43× the final phase's CPU, but
#: lost two candidates whose half-cycle point fails a MuJoCo check the full one passes
#: (docs/results/planner_speed_search.md, 36-lead e and i), so the final re-solves stay full.
#: With `FINAL_RETRY_FULL` ("halfretry", session 39) the 32 searches of session 38 wrote the same
#: gait, cost and verdict as full-cycle re-solves in 32 of 32 (exact replays), but the final
#: phase took 1.11× the CPU (each candidate failing at 30 knots is solved twice; the retry fired
#: 47 times and changed one gait) and the search 1.03×; halffinal alone 0.70× but bittle8 seed
#: 3 wrote a gait 2.17× as costly (planner_speed_search.md, session 39 (branch robustfinal))
FINAL_HALF_CYCLE = False
#: `search_gait(final_retry_full=)`: a candidate whose final re-solve ran on half the knots
#: (`FINAL_HALF_CYCLE`) and is infeasible or fails the final check is re-solved cold on the
#: full NLP, and that plan is judged instead (`planner.search.final_phase.evaluate_final`):
#: the half-cycle re-solve then loses no candidate the full one passes (36-lead i's bittle8
#: seed 3). One task either way, so the final rule and its reading order are unchanged; the
#: templates are not retried (they are planned as the template path plans them). Only with
#: the half-cycle re-solves (`--half-cycle`), which are not the default: see `FINAL_HALF_CYCLE`.
#: Where it lands (session 39 (lead), `benchmarks/retry_points.py`, 41 replayed retries): the
#: half plan's own point in 15, the same optimum to < 1e-3 in 15, another point or infeasible in
#: 11; its one rescue (bittle8 seed 3) was the same plan to 6.5e-6 judged again — a knife-edge
#: MuJoCo verdict, which a robust final check would settle on either path.
FINAL_RETRY_FULL = True
#: `PlannerOptions.swing_wrench` of the search's coarse solves (`search_gait(search_swing_wrench=)`,
#: `plan --search --search-swing-wrench`) and of the final re-solves of its candidates
#: (`search_gait(final_swing_wrench=)`, `--final-swing-wrench`), whatever the options say (None:
#: the options' own); the templates the final phase re-solves keep the options' own ("rows",
#: the template path's), so a rival is the template command's plan. "bounds" (the swing feet's
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
