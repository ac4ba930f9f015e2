"""zwidth mathematics: frequency responses, crossovers, critical gains, designs."""

import models as _models  # noqa: F401  (sets the BLAS thread count before numpy loads)
