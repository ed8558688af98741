"""One-off studies behind the results pages (baselines on the task ids, tracking gains and
curves, crossing fidelity); they use the library, the library never uses them."""
