"""Independent jobs spread over local processes or a Ray cluster (`distributed.run_jobs`)."""
