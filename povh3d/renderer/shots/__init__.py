"""POV-Ray shots: a method's batches turned into images (cache, jobs, clock runs)."""
