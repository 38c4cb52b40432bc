# Reference solution of lesson 04 (injected in place of the exercise cell by the tests).
# ruff: noqa: F821  (Leaf, Port, register_leaf, success_if come from the lesson's cells)
@register_leaf
class ConditionShelterNear(Leaf):
    """SUCCESS where the nearest shelter is within ``distance``."""

    type_name = "Condition_Shelter_Near"
    ports = (Port("distance", float, None, 0.0, "world units"),)

    def evaluate(self, agents, world):
        return success_if(agents.shelter_distance <= self.distance)
