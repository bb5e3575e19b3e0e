"""The lecture notebooks (package data); ``vrlab notebooks FOLDER`` copies them out."""
