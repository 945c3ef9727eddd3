"""Additions to the paper: one module per addition, each switched by one bool of ``additions``.

The default profile (config/paper.yaml) switches every addition on but the ten of persistent
search-and-track, which config/persistent.yaml switches on (search_while_tracking aside);
config/paper_strict.yaml switches every one off and so runs the paper as written. Each module's
docstring says what the paper says, what the addition does, why, and its switch; the paper's
behaviour is the other implementation of the same small interface, chosen once where the
component is built.

Module (and switch ``additions.<module>``): the paper's implementation it replaces.

- peak_extraction: n-hat highest peaks, state_extraction.NHatExtractor (chosen in agent_core);
- extraction_margin: the region S_a(s_k) (chosen in state_extraction.Extractor);
- confirmation: TRACK on the first estimate, state_extraction.FirstEstimate (Extractor);
- investigation: no look from SEARCH, agent_core.NoInvestigation (agent_core);
- newborn_gate: every newborn kept, phd_filter.keep_newborns (phd_filter);
- track_standoff: every admissible action, tracking_control.every_action (tracking_control);
- revisit_fallback: V-bar = {p <= beta}, search_map.unvisited_nodes (search_planning);
- rejoin_cooldown: TRACK on the next estimate, mode_machine.NoCooldown (mode_machine);
- exhaustion_claims: plan over all of V-bar, search_planning.NoClaims (search_planning);
- drop_searched_nodes: own visits only, search_planning.own_visits_only (search_planning);
- regrowing_density: the constant J, search_density.ConstantDecay (search_density);
- persistent_planning: path-cheapest-arc over V-bar, search_planning.SearchPlanner (agent_core);
- search_while_tracking: the best Renyi divergence, tracking_control.best_score (tracking_control);
- track_release: every target tracked, agent_core.KeepAll (agent_core);
- track_coasting: X-hat_k reported, tracking until lost, track_coasting.NoCoasting (agent_core);
- kernel_likelihood: the sensor's own g, bandwidth 0 (phd_filter, tracking_control);
- heavy_peak_confirmation: the streak alone (confirmation.ScanConfirmation);
- track_probation: the timeout alone, mode_machine.NoProbation (mode_machine);
- track_revisit: a coasted target met again by chance, track_revisit.NoRevisit (agent_core);
- measurement_fit: the estimates' least-squares fit, a Track without informations
  (track_coasting).
"""
