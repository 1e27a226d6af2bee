"""Runs pxr's registered validators on a stage."""
from pxr import Usd, UsdShade, UsdValidation


def _register_connectable_behaviors(stage):
    # Validators run in parallel, and UsdShade registers a prim type's connectable
    # behaviour lazily; two threads doing so at once raise a Tf error. Do it here,
    # serially, first.
    for prim in Usd.PrimRange.Stage(stage, Usd.TraverseInstanceProxies(Usd.PrimAllPrimsPredicate)):
        UsdShade.ConnectableAPI(prim).IsContainer()


def validation_errors(stage):
    """Messages of every Error-severity finding of every registered validator."""
    _register_connectable_behaviors(stage)
    registry = UsdValidation.ValidationRegistry()
    context = UsdValidation.ValidationContext(registry.GetOrLoadAllValidators())
    errors = []
    for err in context.Validate(stage):
        if err.GetType() == UsdValidation.ValidationErrorType.Error:
            errors.append(f"{err.GetName()}: {err.GetMessage()}")
    return errors
