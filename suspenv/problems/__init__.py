"""Problems: design space + model + rigs + objectives + constraints (one module each)."""
