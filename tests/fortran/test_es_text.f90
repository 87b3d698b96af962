!> mlid_text's es_text and fixed_text, the one way a report writes a number
!> in a column: a normal number in the column's ESw.dE2 to the byte, any
!> other (an exponent of three digits, a sign the width has no room for, a
!> value too large for an F column) in the fewest characters that hold it,
!> never asterisks, and read back to the digits shown.
program test_es_text
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_positive_inf, &
                                           ieee_negative_inf
  use mlid_kinds, only: wp
  use mlid_text, only: es_text, fixed_text
  use test_checks, only: check, finish
  implicit none
  real(wp) :: back
  character(len=32) :: buf
  integer :: k
  real(wp), parameter :: NORMAL(6) = [0.0_wp, 1.0_wp, -2.5e-7_wp, 6.004119e-14_wp, &
                                      9.9999e98_wp, 1.0e-99_wp]
  real(wp), parameter :: ODD(7) = [1.0e150_wp, -1.0e120_wp, 1.0e-150_wp, 9.99996e99_wp, &
                                   -9.99996e-101_wp, 4.9e-320_wp, 1.5e308_wp]

  do k = 1, size(NORMAL)          ! the bytes every report had
    write (buf, '(es15.6e2)') NORMAL(k)
    call check(es_text(NORMAL(k), 15, 6) == buf(1:15), 'normal number in ES15.6E2: '//buf(1:15))
  end do
  call check(es_text(-1.5_wp, 10, 4) == '-1.5000E+00', 'a sign ES10.4E2 has no room for: '// &
             'one character wider, still E+nn')
  do k = 1, size(ODD)
    buf = es_text(ODD(k), 10, 4)
    call check(index(buf, '*') == 0 .and. index(buf, 'E') > 0 .and. len_trim(buf) >= 10, &
               'no asterisks and an E: '//trim(buf))
    read (buf, *) back
    call check(abs(back - ODD(k)) <= 1.0e-4_wp*abs(ODD(k)), 'reads back: '//trim(buf))
  end do
  call check(es_text(1.0e150_wp, 15, 6) == '  1.000000E+150', 'three-digit exponent, '// &
             'right-justified in the column')
  call check(es_text(9.99996e99_wp, 10, 4) == '1.0000E+100', 'rounding up to 1E+100 takes E+nnn')
  call check(adjustl(es_text(ieee_value(1.0_wp, ieee_quiet_nan), 10, 4)) == 'NaN' .and. &
             adjustl(es_text(ieee_value(1.0_wp, ieee_positive_inf), 10, 4)) == 'Infinity' .and. &
             adjustl(es_text(ieee_value(1.0_wp, ieee_negative_inf), 10, 4)) == '-Infinity', &
             'NaN and the infinities in words')
  call check(fixed_text(1.25_wp, 12, 3) == '       1.250', 'F12.3 as it was')
  buf = fixed_text(3.0e12_wp, 12, 3)
  call check(index(buf, '*') == 0, 'a value too large for F12.3 in ES: '//trim(buf))
  read (buf, *) back
  call check(abs(back - 3.0e12_wp) <= 1.0e-3_wp*3.0e12_wp, 'and it reads back')
  call finish()
end program test_es_text
