"""Records with known effects for judging ``studies discover``: simulated
records with an effect hidden in them (:mod:`.hidden`) and measured records
with an effect whose truth is exact injected into them (:mod:`.injected`).
Used by the tests and the discovery bench, never by discovery itself."""
