"""The figures of a calibration, each module one kind: labels (symbols and units), the canvas (pyplot off screen, the
grid of panels), posterior figures (marginals, pairs, stages), curve figures (records, MAP, predictive band; stress
paths) and the MAP's curves between the records."""
