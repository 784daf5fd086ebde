"""Budget: the accuracy budget, one engine: sensitivities, the budget predicted from a plan and measured from a calibration."""
