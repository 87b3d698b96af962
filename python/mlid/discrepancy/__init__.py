"""What the model is missing: mlid.diagnose, its candidate effects (effects,
terms, score_test), held-out verdicts, the diagnosis it returns; the
model-size and prediction checks and the perfectly-measured-state reduction
(report §5.3)."""
