"""Reading finished runs: the report (Tables II/III, Figure 4, statistics), evaluation in
Gymnasium, the paper's published numbers and the activation figures. Trains nothing."""
