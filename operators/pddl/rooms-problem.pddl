; Two parcels in the lab, one for the office and one for the storeroom.
(define (problem two-parcels)
  (:domain rooms)
  (:objects lab corridor office storeroom - room mail box - parcel)
  (:init (at-robot lab) (at mail lab) (at box lab)
         (door lab corridor) (door corridor lab) (door corridor office) (door office corridor)
         (door corridor storeroom) (door storeroom corridor))
  (:goal (and (at mail office) (at box storeroom))))
