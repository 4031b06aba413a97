"""Model files: step-response curves in DMCplus .mdl and CSV layouts, and the model YAML that names them."""
